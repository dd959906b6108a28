// WebXR's hand input from monohand's hands: a record's 26 OpenXR joints (`xr_joints`, the
// tracker's `xrJoints` option, as `monohand run --xr-joints`) as the 25 joint poses WebXR
// gives (`XRHand`, `XRFrame.getJointPose`), so that code written for a headset's hand input
// (three.js' XRHandModelFactory, for one) can be driven by a webcam. No dependencies; it
// runs in pages, workers and Node alike.
//
// What changes from the record:
// - the joints: WebXR's are OpenXR's without the palm, in the same order, named with
//   hyphens (`thumb-phalanx-proximal`, `pinky-finger-tip`; below, from the record's names);
// - the unit: metres;
// - the frame: WebXR's `viewer` space (x right, y up, z towards the viewer), the camera's
//   own frame (x right, y down, z forward) turned half a turn about its x axis: (x, y, z)
//   becomes (x, -y, -z), and each orientation is that turn times the record's. The joints'
//   own axes are the same in both specs (-Z along the bone towards the finger tip, +Y out
//   of the back of the hand; docs/output-format.md, "XR joint object"), so nothing else
//   changes. A page in an XR session that wants them elsewhere multiplies by that space's
//   pose.

/** WebXR's hand joints (`XRHandJoint`), in the order of the spec's enumeration. */
export const WEBXR_JOINT_NAMES = Object.freeze([
  'wrist',
  'thumb-metacarpal', 'thumb-phalanx-proximal', 'thumb-phalanx-distal', 'thumb-tip',
  ...['index', 'middle', 'ring', 'pinky'].flatMap((f) => [
    `${f}-finger-metacarpal`, `${f}-finger-phalanx-proximal`, `${f}-finger-phalanx-intermediate`,
    `${f}-finger-phalanx-distal`, `${f}-finger-tip`]),
]);

/**
 * The WebXR name of an OpenXR joint record's name (`wrist`, `thumb_proximal`,
 * `little_tip`, ...), or `null` for the palm, which WebXR does not have.
 */
export function webxrJointName(openxrName) {
  if (openxrName === 'palm') return null;
  if (openxrName === 'wrist') return 'wrist';
  const [finger, part] = openxrName.split('_');
  const digit = finger === 'thumb' ? 'thumb' : `${finger === 'little' ? 'pinky' : finger}-finger`;
  const bone = part === 'metacarpal' || part === 'tip' ? part : `phalanx-${part}`;
  return `${digit}-${bone}`;
}

/**
 * A hand's joints as WebXR gives them: a `Map` from each of the 25 joint names
 * ({@link WEBXR_JOINT_NAMES}, in that order) to an object shaped as `XRJointPose`:
 * `{ transform: { position: {x, y, z, w: 1}, orientation: {x, y, z, w}, matrix }, radius }`
 * (metres, in the camera as WebXR's `viewer` space; `matrix` a column-major
 * `Float32Array(16)`, as `XRRigidTransform.matrix`). `null` when the hand has no
 * `xr_joints` (not fitted in 3D, or the tracker made without `xrJoints: true`).
 */
export function webxrJoints(hand) {
  const joints = hand?.xr_joints;
  if (!Array.isArray(joints) || joints.length !== 26) return null;
  const poses = new Map();
  for (const j of joints) {
    const name = webxrJointName(j.name);
    if (name === null) continue;
    const [px, py, pz] = j.position_mm;
    const [qx, qy, qz, qw] = j.orientation_xyzw;
    // Half a turn about x, (1, 0, 0, 0) as [x, y, z, w], times the joint's rotation.
    const q = { x: qw, y: -qz, z: qy, w: -qx };
    const position = { x: px / 1000, y: -py / 1000, z: -pz / 1000, w: 1 };
    poses.set(name, {
      transform: { position, orientation: q, matrix: rigidMatrix(position, q) },
      radius: j.radius_mm / 1000,
    });
  }
  return poses;
}

/** The column-major 4x4 of a rotation (unit quaternion) and a translation. */
function rigidMatrix(p, q) {
  const { x, y, z, w } = q;
  return Float32Array.of(
    1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w), 0,
    2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w), 0,
    2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y), 0,
    p.x, p.y, p.z, 1,
  );
}
