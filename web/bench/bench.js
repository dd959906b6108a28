// The side-by-side benchmark (issues 31 and 45): the same raw RGBA clip (640x480, as
// web-test.sh makes it) through monohand's tracker and through two of Google's MediaPipe
// packages, one hand tracked, in the same page, one after the other, alternating for
// `rounds` rounds:
// - monohand twice a round: like for like (one landmark pass a crop, as MediaPipe; native
//   `run`'s `--no-mirror-pass`) and with its defaults (the mirror pass: two), each in f32
//   (the default) and in int8 (`precision: 'int8'`);
// - `@mediapipe/tasks-vision`'s HandLandmarker with `delegate: 'CPU'` (MediaPipe's XNNPACK
//   in WebAssembly, its SIMD build chosen by FilesetResolver; runningMode VIDEO, numHands 1,
//   the same two networks as monohand, given as a model bundle, the `task` URL): the honest
//   anchor, the networks on the CPU as monohand runs them;
// - `@mediapipe/hands`, MediaPipe's legacy web solution (its SIMD WebAssembly build, chosen
//   by the package; maxNumHands 1, modelComplexity 1), whose graph runs on WebGL: on a
//   machine without a GPU, Chromium's software renderer.
// Each system's time for a frame runs from the raw bytes to its result: for monohand an
// ImageData over them and `track`; for HandLandmarker an ImageData over them and
// `detectForVideo`; for @mediapipe/hands the bytes put on a canvas and `send` (its results
// arrive before `send` resolves). The first frame of each round is left out (warm-up).
// Tasks' 2D keypoints are compared with monohand's like-for-like ones, frame by frame, as a
// check that both do the same work (`agreement`). The result is in `window.benchResult`.
// URL parameters: clip (the .rgba file), w, h, fps, rounds (default 2), task (the model
// bundle's URL).

import { createTracker } from '../monohand.js';
import { readClip } from '../test/clip.js';
import { FilesetResolver, HandLandmarker } from './node_modules/@mediapipe/tasks-vision/vision_bundle.mjs';

const status = document.getElementById('status');
const say = (text) => { status.textContent = text; };
const params = new URLSearchParams(location.search);
const w = Number(params.get('w'));
const h = Number(params.get('h'));
const fps = Number(params.get('fps') ?? 30);
const rounds = Number(params.get('rounds') ?? 2);
// @mediapipe/hands runs this many of the clip's first frames (all by default): on a machine
// without a GPU its WebGL graph takes about 2 s a frame, and its line is only context.
const legacyFrames = Number(params.get('legacy_frames') ?? 0);

const nextTask = () => new Promise((resolve) => setTimeout(resolve, 0));

/** The 2D keypoints of a run: frame index -> 21 [x, y] in pixels. */
const keypoints = () => new Map();

async function monohandRound(clip, mirrorPass, precision = 'f32') {
  const tracker = await createTracker({ weights: '../weights/', hands: 1, mirrorPass, precision });
  const ms = [];
  let found = 0;
  const points = keypoints();
  const take = (frames) => {
    for (const f of frames) {
      if (f.hands.some((hand) => hand.joints_3d_mm)) found += 1;
      const hand = f.hands.find((one) => one.keypoints_2d?.some(([, , p]) => p > 0));
      if (hand) points.set(f.frame, hand.keypoints_2d.map(([x, y]) => [x, y]));
    }
  };
  for (let i = 0; i < clip.n; i++) {
    const t = performance.now();
    const image = clip.frame(i);
    const frames = await tracker.track(image, i / fps);
    ms.push(performance.now() - t);
    take(frames);
    await nextTask();
  }
  take(await tracker.finish());
  if (typeof tracker.close === 'function') tracker.close();
  else if (typeof tracker.terminate === 'function') tracker.terminate();
  return { ms, found, points };
}

let tasks = null;
let tasksClockMs = 0;

async function tasksRound(clip) {
  if (!tasks) {
    // The WebAssembly files from this folder's node_modules (npm, pinned in
    // package-lock.json); FilesetResolver picks the SIMD build when the browser has SIMD.
    const fileset = await FilesetResolver.forVisionTasks(
      new URL('node_modules/@mediapipe/tasks-vision/wasm', location.href).href);
    tasks = await HandLandmarker.createFromOptions(fileset, {
      baseOptions: { modelAssetPath: new URL(params.get('task'), location.href).href, delegate: 'CPU' },
      runningMode: 'VIDEO',
      numHands: 1,
      minHandDetectionConfidence: 0.5,
      minHandPresenceConfidence: 0.5,
      minTrackingConfidence: 0.5,
    });
  } else {
    // A new graph in the same WebAssembly instance: no tracking carried over from the last
    // round (as monohand's new tracker and @mediapipe/hands' reset).
    await tasks.setOptions({ numHands: 1 });
  }
  const ms = [];
  let found = 0;
  const points = keypoints();
  for (let i = 0; i < clip.n; i++) {
    const t = performance.now();
    const image = clip.frame(i);
    // Timestamps in ms, increasing across rounds too.
    const result = tasks.detectForVideo(image, Math.round(tasksClockMs + (1000 * i) / fps));
    ms.push(performance.now() - t);
    const hand = result.landmarks?.[0];
    if (hand) {
      found += 1;
      points.set(i, hand.map(({ x, y }) => [x * w, y * h]));
    }
    await nextTask();
  }
  tasksClockMs += (1000 * clip.n) / fps + 1000;
  return { ms, found, points };
}

let mediapipe = null;
let lastResults = null;

async function mediapipeRound(clip, canvas) {
  if (!mediapipe) {
    // eslint-disable-next-line no-undef
    mediapipe = new Hands({ locateFile: (file) => `node_modules/@mediapipe/hands/${file}` });
    mediapipe.setOptions({
      maxNumHands: 1, modelComplexity: 1, minDetectionConfidence: 0.5, minTrackingConfidence: 0.5,
      selfieMode: false,
    });
    mediapipe.onResults((results) => { lastResults = results; });
    await mediapipe.initialize();
  } else {
    mediapipe.reset();
  }
  const ctx = canvas.getContext('2d');
  const ms = [];
  let found = 0;
  const n = legacyFrames > 1 ? Math.min(legacyFrames, clip.n) : clip.n;
  for (let i = 0; i < n; i++) {
    lastResults = null;
    const t = performance.now();
    ctx.putImageData(clip.frame(i), 0, 0);
    await mediapipe.send({ image: canvas });
    ms.push(performance.now() - t);
    if (lastResults?.multiHandLandmarks?.length) found += 1;
    await nextTask();
  }
  return { ms, found };
}

const median = (values) => {
  const sorted = [...values].sort((a, b) => a - b);
  const m = sorted.length >> 1;
  return sorted.length % 2 ? sorted[m] : (sorted[m - 1] + sorted[m]) / 2;
};

const summary = (runs) => {
  const after = runs.flatMap((r) => r.ms.slice(1));
  const total = after.reduce((s, x) => s + x, 0);
  const perRound = runs.map((r) => (1000 * (r.ms.length - 1)) / r.ms.slice(1).reduce((s, x) => s + x, 0));
  return {
    // The median of the rounds' fps (each round: its frames after the first over their time).
    median_round_fps: median(perRound),
    fps: (1000 * after.length) / total,
    median_ms: median(after),
    per_round_fps: perRound,
    frames_with_hand: runs.map((r) => r.found),
  };
};

/**
 * Two runs' 2D keypoints, frame by frame: over the frames where both found a hand, the mean
 * distance of the 21 joints in pixels; its median and maximum over those frames, and the
 * mean offset (theirs - ours) over all those joints.
 */
function agreement(ours, theirs) {
  const perFrame = [];
  const offset = [0, 0];
  for (const [frame, a] of ours) {
    const b = theirs.get(frame);
    if (!b) continue;
    perFrame.push(a.reduce((s, [x, y], j) => s + Math.hypot(x - b[j][0], y - b[j][1]), 0) / a.length);
    a.forEach(([x, y], j) => { offset[0] += b[j][0] - x; offset[1] += b[j][1] - y; });
  }
  const joints = perFrame.length * 21;
  return {
    frames_monohand: ours.size,
    frames_tasks: theirs.size,
    frames_both: perFrame.length,
    median_px: perFrame.length ? median(perFrame) : null,
    max_px: perFrame.length ? Math.max(...perFrame) : null,
    mean_offset_px: joints ? offset.map((o) => o / joints) : null,
  };
}

/** The WebGL renderer @mediapipe/hands' graph ran on (SwiftShader: software, no GPU). */
function webglRenderer() {
  const gl = document.createElement('canvas').getContext('webgl2');
  if (!gl) return 'no WebGL 2';
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  return String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
}

async function main() {
  const clip = await readClip(params.get('clip'), w, h);
  const canvas = document.getElementById('view');
  canvas.width = w;
  canvas.height = h;
  const ours = [];
  const oursDefaults = [];
  const oursInt8 = [];
  const oursInt8Defaults = [];
  const tasksRuns = [];
  const theirs = [];
  for (let r = 0; r < rounds; r++) {
    say(`round ${r + 1} of ${rounds}: monohand, like for like`);
    ours.push(await monohandRound(clip, false));
    say(`round ${r + 1} of ${rounds}: monohand, defaults (mirror pass)`);
    oursDefaults.push(await monohandRound(clip, true));
    say(`round ${r + 1} of ${rounds}: monohand int8, like for like`);
    oursInt8.push(await monohandRound(clip, false, 'int8'));
    say(`round ${r + 1} of ${rounds}: monohand int8, defaults (mirror pass)`);
    oursInt8Defaults.push(await monohandRound(clip, true, 'int8'));
    say(`round ${r + 1} of ${rounds}: MediaPipe Tasks HandLandmarker, CPU`);
    tasksRuns.push(await tasksRound(clip));
    say(`round ${r + 1} of ${rounds}: @mediapipe/hands`);
    theirs.push(await mediapipeRound(clip, canvas));
  }
  tasks?.close();
  say('done');
  return {
    frames: clip.n,
    width: w,
    height: h,
    rounds,
    monohand: summary(ours),
    monohand_defaults: summary(oursDefaults),
    monohand_int8: summary(oursInt8),
    monohand_int8_defaults: summary(oursInt8Defaults),
    tasks: summary(tasksRuns),
    mediapipe: { ...summary(theirs), frames: theirs[0]?.ms.length ?? 0 },
    // The last round's: by then each system is warm.
    agreement: agreement(ours.at(-1).points, tasksRuns.at(-1).points),
    // monohand's int8 keypoints against its f32 ones (like for like, the last round).
    agreement_int8: agreement(ours.at(-1).points, oursInt8.at(-1).points),
    webgl_renderer: webglRenderer(),
    user_agent: navigator.userAgent,
  };
}

main().then(
  (result) => { window.benchResult = result; },
  (error) => {
    say(`error: ${error.message}`);
    window.benchResult = { error: String(error.message ?? error) };
  },
);
