// Compares the page's records with native `monohand run`'s on the same frames, to the
// tolerances of issue 45: 2D keypoints within 0.02 px, 3D joints within 0.05 mm, the same hands
// (count, side, id) in every frame; where native wrote OpenXR joints (`run --xr-joints`),
// the page's (`xrJoints: true`) at the same tolerance in mm, their orientations within
// 2e-3 (quaternion components) and their radii within 0.05 mm. Prints one line per failure and a summary as JSON on
// its last line; exits 1 if anything differs beyond the tolerances.
//
//   node compare.mjs native.jsonl web.jsonl

import { readFileSync } from 'node:fs';

const PX = 0.02;
const MM = 0.05;
// A joint 0.05 mm off on a 25 mm bone turns it by 2e-3 rad (quaternion components by about half that).
const QUAT = 2e-3;

const read = (file) => readFileSync(file, 'utf8').split('\n').filter((l) => l.trim()).map((l) => JSON.parse(l));
const [nativeFile, webFile] = process.argv.slice(2);
const native = read(nativeFile);
const web = read(webFile);
const failures = [];
let hands3d = 0;
let maxPx = 0;
let maxMm = 0;
let xrHands = 0;
let maxXrMm = 0;
let maxXrQuat = 0;

const maxDiff = (a, b, dims) => {
  let m = 0;
  for (let j = 0; j < a.length; j++) for (let d = 0; d < dims; d++) m = Math.max(m, Math.abs(a[j][d] - b[j][d]));
  return m;
};

if (native.length !== web.length) failures.push(`${native.length} native frames, ${web.length} in the browser`);
for (let i = 0; i < Math.min(native.length, web.length); i++) {
  const [n, w] = [native[i], web[i]];
  if (n.frame !== w.frame) failures.push(`record ${i}: frame ${n.frame} native, ${w.frame} in the browser`);
  if (n.hands.length !== w.hands.length) {
    failures.push(`frame ${n.frame}: ${n.hands.length} hands native, ${w.hands.length} in the browser`);
    continue;
  }
  n.hands.forEach((hn, k) => {
    const hw = w.hands[k];
    const where = `frame ${n.frame} hand ${k}`;
    if (hn.side !== hw.side || hn.id !== hw.id) failures.push(`${where}: ${hn.side} #${hn.id} native, ${hw.side} #${hw.id} in the browser`);
    const px = maxDiff(hn.keypoints_2d, hw.keypoints_2d, 2);
    maxPx = Math.max(maxPx, px);
    if (!(px <= PX)) failures.push(`${where}: keypoints differ by ${px.toFixed(3)} px (at most ${PX})`);
    if (!hn.joints_3d_mm !== !hw.joints_3d_mm) {
      failures.push(`${where}: 3D ${hn.joints_3d_mm ? '' : 'not '}fitted natively, ${hw.joints_3d_mm ? '' : 'not '}in the browser`);
    } else if (hn.joints_3d_mm) {
      hands3d += 1;
      const mm = maxDiff(hn.joints_3d_mm, hw.joints_3d_mm, 3);
      maxMm = Math.max(maxMm, mm);
      if (!(mm <= MM)) failures.push(`${where}: 3D joints differ by ${mm.toFixed(3)} mm (at most ${MM})`);
    }
    if (hn.xr_joints) {
      if (!hw.xr_joints || hw.xr_joints.length !== hn.xr_joints.length) {
        failures.push(`${where}: ${hn.xr_joints.length} OpenXR joints native, ${hw.xr_joints?.length ?? 'none'} in the browser`);
        return;
      }
      xrHands += 1;
      const names = hn.xr_joints.every((j, i) => j.name === hw.xr_joints[i].name);
      if (!names) failures.push(`${where}: the OpenXR joints' names differ`);
      const pos = (h) => h.xr_joints.map((j) => [...j.position_mm, j.radius_mm]);
      const mm = maxDiff(pos(hn), pos(hw), 4);
      const q = maxDiff(hn.xr_joints.map((j) => j.orientation_xyzw), hw.xr_joints.map((j) => j.orientation_xyzw), 4);
      maxXrMm = Math.max(maxXrMm, mm);
      maxXrQuat = Math.max(maxXrQuat, q);
      if (!(mm <= MM)) failures.push(`${where}: OpenXR joints or radii differ by ${mm.toFixed(3)} mm (at most ${MM})`);
      if (!(q <= QUAT)) failures.push(`${where}: OpenXR orientations differ by ${q.toExponential(2)} (at most ${QUAT})`);
    }
  });
}
for (const f of failures.slice(0, 20)) console.error(f);
if (failures.length > 20) console.error(`... and ${failures.length - 20} more`);
console.log(JSON.stringify({ frames: web.length, hands_3d: hands3d, max_px: maxPx, max_mm: maxMm,
  xr_hands: xrHands, max_xr_mm: maxXrMm, max_xr_quat: maxXrQuat, failures: failures.length }));
process.exit(failures.length ? 1 : 0);
