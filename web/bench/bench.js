// The side-by-side benchmark (issue 31): the same raw RGBA clip (640x480, as web-test.sh
// makes it) through monohand's tracker and through Google's `@mediapipe/hands` (its SIMD
// WebAssembly build, chosen by the package itself when the browser has SIMD;
// maxNumHands 1, modelComplexity 1), one hand tracked, in the same page, one after the
// other, alternating for `rounds` rounds. monohand runs twice a round: like for like (one
// landmark pass a crop, as MediaPipe; native `run`'s `--no-mirror-pass`) and with its
// defaults (the mirror pass: two). Each system's time for a frame runs from the raw
// bytes to its result: for monohand an ImageData over them and `track`; for MediaPipe the
// bytes put on a canvas and `send` (its results arrive before `send` resolves). The first
// frame of each round is left out (warm-up). The result is in `window.benchResult`.
// URL parameters: clip (the .rgba file), w, h, fps, rounds (default 2).

import { createTracker } from '../monohand.js';
import { readClip } from '../test/clip.js';

const status = document.getElementById('status');
const say = (text) => { status.textContent = text; };
const params = new URLSearchParams(location.search);
const w = Number(params.get('w'));
const h = Number(params.get('h'));
const fps = Number(params.get('fps') ?? 30);
const rounds = Number(params.get('rounds') ?? 2);

const nextTask = () => new Promise((resolve) => setTimeout(resolve, 0));

async function monohandRound(clip, mirrorPass) {
  const tracker = await createTracker({ weights: '../weights/', hands: 1, mirrorPass });
  const ms = [];
  let found = 0;
  for (let i = 0; i < clip.n; i++) {
    const t = performance.now();
    const image = clip.frame(i);
    const frames = tracker.track(image, i / fps);
    ms.push(performance.now() - t);
    for (const f of frames) if (f.hands.some((hand) => hand.joints_3d_mm)) found += 1;
    await nextTask();
  }
  for (const f of tracker.finish()) if (f.hands.some((hand) => hand.joints_3d_mm)) found += 1;
  return { ms, found };
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
  for (let i = 0; i < clip.n; i++) {
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

const summary = (runs) => {
  const after = runs.flatMap((r) => r.ms.slice(1));
  const total = after.reduce((s, x) => s + x, 0);
  const sorted = [...after].sort((a, b) => a - b);
  return {
    fps: (1000 * after.length) / total,
    median_ms: sorted[Math.floor(sorted.length / 2)],
    per_round_fps: runs.map((r) => (1000 * (r.ms.length - 1)) / r.ms.slice(1).reduce((s, x) => s + x, 0)),
    frames_with_hand: runs.map((r) => r.found),
  };
};

/** The WebGL renderer MediaPipe's graph ran on (SwiftShader: software, no GPU). */
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
  const theirs = [];
  for (let r = 0; r < rounds; r++) {
    say(`round ${r + 1} of ${rounds}: monohand, like for like`);
    ours.push(await monohandRound(clip, false));
    say(`round ${r + 1} of ${rounds}: monohand, defaults (mirror pass)`);
    oursDefaults.push(await monohandRound(clip, true));
    say(`round ${r + 1} of ${rounds}: @mediapipe/hands`);
    theirs.push(await mediapipeRound(clip, canvas));
  }
  say('done');
  return {
    frames: clip.n,
    rounds,
    monohand: summary(ours),
    monohand_defaults: summary(oursDefaults),
    mediapipe: summary(theirs),
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
