// Checks web/webxr.js (WebXR's 25 joint poses from a record's 26 OpenXR joints) on the
// records native `monohand run --xr-joints` wrote (scripts/web-test.sh): for every fitted
// hand, the joints are WebXR's, in its order (the spec's list, and three.js' own, which its
// WebXR hand models look their bones up by); each position is the OpenXR joint's in
// metres in WebXR's viewer space (x, -y, -z); each matrix is a rotation whose -Z runs along
// the joint's bone to the next joint (a tip keeps its distal joint's) and whose +Y points
// out of the back of the hand; the radius is the record's in metres. Prints a summary as
// JSON; exits 1 on the first failure.
//
//   node webxr.mjs native.jsonl [three's XRHandMeshModel.js]

import { readFileSync } from 'node:fs';
import { WEBXR_JOINT_NAMES, webxrJointName, webxrJoints } from '../webxr.js';

const [recordsFile, threeFile] = process.argv.slice(2);
const fail = (why) => { console.error(`webxr: ${why}`); process.exit(1); };

if (WEBXR_JOINT_NAMES.length !== 25) fail(`${WEBXR_JOINT_NAMES.length} WebXR joint names`);
if (threeFile) {
  // three.js' list, as its hand models have it: the names the WebXR runtime gives.
  const src = readFileSync(threeFile, 'utf8');
  const theirs = [...src.matchAll(/'((?:wrist|thumb|index|middle|ring|pinky)[a-z-]*)'/g)].map((m) => m[1]);
  if (theirs.join() !== WEBXR_JOINT_NAMES.join()) fail(`three.js names the joints ${theirs.join()}`);
}
if (webxrJointName('palm') !== null || webxrJointName('little_intermediate') !== 'pinky-finger-phalanx-intermediate'
  || webxrJointName('thumb_distal') !== 'thumb-phalanx-distal') fail('a joint name is not WebXR\'s');

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const unit = (a) => { const n = Math.hypot(...a); return a.map((x) => x / n); };
const angle = (a, b) => Math.acos(Math.min(1, Math.max(-1, dot(unit(a), unit(b)))));
const column = (m, c) => [m[4 * c], m[4 * c + 1], m[4 * c + 2]];
const at = (pose) => { const p = pose.transform.position; return [p.x, p.y, p.z]; };

// Each digit's chain, WebXR's names: -Z of each joint but the tip runs to the next one.
const chains = [['thumb-metacarpal', 'thumb-phalanx-proximal', 'thumb-phalanx-distal', 'thumb-tip'],
  ...['index', 'middle', 'ring', 'pinky'].map((f) => ['metacarpal', 'phalanx-proximal',
    'phalanx-intermediate', 'phalanx-distal', 'tip'].map((b) => `${f}-finger-${b}`))];

const records = readFileSync(recordsFile, 'utf8').split('\n').filter(Boolean).map((l) => JSON.parse(l));
let hands = 0;
let maxPos = 0;
let maxAlong = 0;
let minBack = 1;
let unfitted = 0;
for (const record of records) {
  for (const hand of record.hands) {
    const poses = webxrJoints(hand);
    if (!hand.joints_3d_mm) {
      unfitted += 1;
      if (poses !== null) fail(`frame ${record.frame}: a hand without 3D has WebXR joints`);
      continue;
    }
    if (!hand.xr_joints) fail(`frame ${record.frame}: a fitted hand has no xr_joints (run --xr-joints)`);
    if (poses === null || [...poses.keys()].join() !== WEBXR_JOINT_NAMES.join()) {
      fail(`frame ${record.frame}: the joints are not WebXR's 25 in order`);
    }
    hands += 1;
    hand.xr_joints.slice(1).forEach((j, k) => {
      const pose = poses.get(WEBXR_JOINT_NAMES[k]);
      const want = [j.position_mm[0] / 1000, -j.position_mm[1] / 1000, -j.position_mm[2] / 1000];
      maxPos = Math.max(maxPos, ...sub(at(pose), want).map(Math.abs));
      if (Math.abs(pose.radius - j.radius_mm / 1000) > 1e-12) fail(`${j.name}: radius ${pose.radius} m, ${j.radius_mm} mm`);
      const m = pose.transform.matrix;
      const [x, y, z] = [0, 1, 2].map((c) => column(m, c));
      const orthonormal = [dot(x, x), dot(y, y), dot(z, z)].every((v) => Math.abs(v - 1) < 1e-5)
        && [dot(x, y), dot(y, z), dot(x, z)].every((v) => Math.abs(v) < 1e-5) && dot(cross(x, y), z) > 0.99999;
      if (!orthonormal) fail(`${j.name}: the matrix is not a rotation`);
      if (Math.max(...sub(column(m, 3), want).map(Math.abs)) > 1e-6) fail(`${j.name}: the matrix's translation is not its position`);
    });
    const minusZ = (name) => column(poses.get(name).transform.matrix, 2).map((v) => -v);
    const bones = [['wrist', 'middle-finger-metacarpal']];
    for (const chain of chains) for (let i = 0; i + 1 < chain.length; i++) bones.push([chain[i], chain[i + 1]]);
    for (const [from, to] of bones) {
      maxAlong = Math.max(maxAlong, angle(minusZ(from), sub(at(poses.get(to)), at(poses.get(from)))));
    }
    for (const chain of chains) {
      const [tip, distal] = [chain[chain.length - 1], chain[chain.length - 2]];
      if (angle(minusZ(tip), minusZ(distal)) > 1e-5) fail(`${tip}: not its distal joint's orientation`);
    }
    // The back of the hand: (index - wrist) x (pinky - wrist) points out of the palm of a
    // right hand in a right-handed frame, out of the back of a left one.
    const w = at(poses.get('wrist'));
    const palmSide = cross(sub(at(poses.get('index-finger-phalanx-proximal')), w),
      sub(at(poses.get('pinky-finger-phalanx-proximal')), w));
    const back = hand.side === 'right' ? palmSide.map((v) => -v) : palmSide;
    minBack = Math.min(minBack, dot(unit(column(poses.get('wrist').transform.matrix, 1)), unit(back)));
  }
}
if (hands === 0) fail('no fitted hand in the records');
if (maxPos > 1e-9) fail(`positions off by ${maxPos} m`);
if (maxAlong > 1e-4) fail(`a joint's -Z is ${maxAlong} rad off its bone`);
if (minBack < 0.8) fail(`the wrist's +Y is ${Math.acos(minBack)} rad off the back of the hand`);
console.log(JSON.stringify({ hands, unfitted, max_position_m: maxPos, max_bone_angle_rad: maxAlong,
  min_wrist_y_dot_back: minBack }));
