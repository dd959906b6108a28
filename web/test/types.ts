// Checks web/monohand.d.ts with the TypeScript compiler (strict): a page's use of the
// tracker and of every field of the records must type-check, and misuses must not
// (`@ts-expect-error` fails the check if the line it marks compiles). Run by
// scripts/web-test.sh (`tsc -p web/tsconfig.json`); never executed.

import {
  createTracker, DEFAULT_WEIGHTS, unsupportedReason, webxrJoints, WEBXR_JOINT_NAMES,
  type FrameRecord, type HandRecord, type TrackerOptions, type WebXRJointPose,
} from '../monohand.js';

export async function example(ctx: CanvasRenderingContext2D, video: HTMLVideoElement): Promise<number[]> {
  const why: string | null = unsupportedReason();
  if (why !== null) throw new Error(why);
  const options: TrackerOptions = {
    weights: './weights/', palm: DEFAULT_WEIGHTS.palm, landmark: new Uint8Array(0), hands: 1,
    detectEvery: 10, mirrorPass: false, threads: 2, xrJoints: true, camera: { fx: 500, fy: 500, cx: 319.5, cy: 239.5, width: 640, height: 480 },
  };
  const tracker = await createTracker(options);
  const frames: FrameRecord[] = await tracker.track(ctx.getImageData(0, 0, 640, 480), video.currentTime);
  const bitmap: ImageBitmap = await createImageBitmap(video);
  const more: FrameRecord[] = await tracker.track(bitmap, video.currentTime + 0.04);
  // @ts-expect-error: track resolves later; its records are not there at once.
  const notYet: FrameRecord[] = tracker.track(ctx.getImageData(0, 0, 640, 480), 1);
  const depths: number[] = [tracker.threads, notYet.length];
  for (const frame of [...frames, ...more, ...await tracker.finish()]) {
    const cam = frame.cameras?.[0];
    if (cam && cam.source === 'generic') depths.push(cam.fx);
    for (const hand of frame.hands) {
      const h: HandRecord = hand;
      const [u, v, confidence] = h.keypoints_2d[8];
      depths.push(u + v + confidence);
      if (h.joints_3d_mm) depths.push(h.joints_3d_mm[0][2]);
      if (h.pose) depths.push(h.pose.translation_mm[2] + h.pose.quaternion_xyzw[3] + h.pose.angles_rad[0]);
      depths.push(h.id ?? -1, h.score ?? 0, h.side_score ?? 0, h.depth_px?.[20] ?? 0);
      if (h.side === 'left' || h.side === 'right') depths.push(h.box?.[0] ?? 0);
      if (h.oriented_box) depths.push(h.oriented_box.angle_deg);
      if (h.xr_joints) depths.push(h.xr_joints[1].position_mm[2], h.xr_joints[0].orientation_xyzw[3], h.xr_joints[25].radius_mm);
      const xr: Map<string, WebXRJointPose> | null = webxrJoints(h);
      const tip = xr?.get(WEBXR_JOINT_NAMES[24]);
      if (tip) depths.push(tip.transform.position.z, tip.transform.matrix[14], tip.radius);
      // @ts-expect-error: a hand has 21 joints.
      depths.push(h.keypoints_2d[21][0]);
    }
    depths.push(frame.frame, frame.time_s ?? 0, frame.timings_ms?.vision ?? 0);
  }
  const notes: string[] = await tracker.notes();
  depths.push(notes.length);
  tracker.close();
  // @ts-expect-error: the side is 'left' or 'right'.
  const wrong: HandRecord['side'] = 'up';
  // @ts-expect-error: hands is a number.
  await createTracker({ hands: '2' });
  return depths.concat(wrong.length);
}
