// The demo page (web/index.html): the webcam or a video file in, the tracked hands drawn
// over it in 3D (web/overlay.js), the fps, and the records to download as JSON Lines.
// Every failure ends in a message on the page that says what is wrong and what to do: an
// unsupported browser, weights missing or corrupt, a camera denied, absent or busy, a video
// the browser cannot play.
//
// URL parameters: `weights` (the weights' folder, default ./weights/), `start=camera`
// (start the camera at once, without the button; the browser test uses it), `mirror=0`
// (the "mirror pass" box unticked: one landmark pass a hand, about twice the frame rate),
// `view3d=webxr` (the 3D view's choice: three.js' own WebXR hand, driven through WebXR's
// joint poses, web/webxr-hand.js, instead of monohand's skinned mesh, web/hand3d.js).
//
// The page's state is in `window.monohandDemo` (read by the browser test,
// web/test/camera.mjs): `state` ('loading', 'ready', 'running', 'stopped' or 'error'),
// `message`, `frames` (frames tracked), `framesWithHand3d`, `hands3d`, `frameMs`,
// `hand3dFrames` (frames the three.js view drew a hand in), `hand3d` (why there is no such
// view, if there is none), `mirrorPass` (the tracker's setting), `threads` (the threads it
// runs on), `framesTicked` (frames during whose tracking the page's own timer ticked),
// `view3d` (the 3D view shown, 'mesh' or 'webxr'), and with the WebXR view `webxrBones`
// (per side, the bones three.js' hand mesh found by WebXR's joint names) and
// `webxrMaxBoneOffsetMm` (the farthest any of them was drawn from its WebXR joint).

import { createTracker, unsupportedReason } from './monohand.js';
import { drawOverlay } from './overlay.js';

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
if (params.get('mirror') === '0') $('mirror').checked = false;
if (params.get('view3d') === 'webxr') $('view3d').value = 'webxr';
const demo = {
  state: 'loading', message: '', frames: 0, framesWithHand3d: 0, hands3d: 0, frameMs: [],
  framesTicked: 0, hand3dFrames: 0, hand3d: '', mirrorPass: null, threads: null, view3d: null,
  webxrBones: null, webxrMaxBoneOffsetMm: null,
};
window.monohandDemo = demo;

function say(text, { error = false } = {}) {
  const el = $('message');
  el.textContent = text;
  el.className = error ? 'error' : '';
  el.setAttribute('role', error ? 'alert' : 'status');
  demo.message = text;
  if (error) demo.state = 'error';
}

/** The message for a failed `getUserMedia`, by the error's name. */
export function cameraMessage(e) {
  const what = `${e?.name ?? 'Error'}: ${e?.message ?? e}`;
  switch (e?.name) {
    case 'NotAllowedError':
    case 'SecurityError':
      return `The camera was denied (${what}). Allow this page to use the camera in the `
        + 'browser\'s site settings (the camera icon by the address) and press Start camera '
        + 'again, or open a video file.';
    case 'NotFoundError':
    case 'OverconstrainedError':
      return `No camera was found (${what}). Connect one and press Start camera again, or `
        + 'open a video file.';
    case 'NotReadableError':
    case 'AbortError':
      return `The camera could not be started: another program may be using it (${what}).`;
    default:
      return `The camera could not be started (${what}).`;
  }
}

let tracker = null;
let handView = null;
let records = [];
let running = null; // { video, stop() }

const canvas = $('view');
const ctx = canvas.getContext('2d');
// The frame being tracked, read from the video into a canvas of its own; the page's canvas
// shows it with its overlay once the tracker is done with it.
const grab = document.createElement('canvas');
const grabCtx = grab.getContext('2d', { willReadFrequently: true });

function resetRecords() {
  records = [];
  Object.assign(demo, {
    frames: 0, framesWithHand3d: 0, hands3d: 0, frameMs: [], framesTicked: 0, hand3dFrames: 0,
  });
  $('download').disabled = true;
}

async function showNotes() {
  const notes = await tracker.notes();
  if (notes.length) $('notes').textContent = notes.join(' ');
}

// The page's own clock: a timer that ticks while the tracker works in its worker (the
// browser test checks that it does, frame by frame: `framesTicked`).
let ticks = 0;
setInterval(() => { ticks += 1; }, 4);

/** Tracks the frames of a playing `<video>` until stopped or ended, drawing each. */
function trackVideo(video, { live, label }) {
  const w = video.videoWidth;
  const h = video.videoHeight;
  canvas.width = w;
  canvas.height = h;
  grab.width = w;
  grab.height = h;
  const t0 = performance.now();
  let lastTime = -1;
  let stopped = false;
  const recent = [];
  let lastPresented = -1;
  let busy = false;
  let inFlight = Promise.resolve();
  const step = (_now, metadata) => {
    if (stopped) return;
    if (!live && video.ended) {
      finish();
      return;
    }
    // A file plays slower while the tracker misses frames (each time a frame was skipped,
    // 0.7 times as fast, down to a tenth), so that nearly every frame gets tracked; a
    // camera cannot wait, and its frames that come while one is tracked are dropped.
    if (!live && metadata?.presentedFrames !== undefined) {
      if (lastPresented >= 0 && metadata.presentedFrames - lastPresented > 1 && video.playbackRate > 0.1) {
        video.playbackRate = Math.max(0.1, video.playbackRate * 0.7);
      }
      lastPresented = metadata.presentedFrames;
    }
    // A camera's frames get the page's clock; a file's its own times (a time seen already
    // is not tracked twice).
    const timeS = live ? (performance.now() - t0) / 1000 : video.currentTime;
    // The tracker works in a worker: the page draws and answers meanwhile. Frames that
    // come while it works on one are not given to it (a file slows down for them, above).
    if (timeS > lastTime && video.readyState >= 2 && !busy) {
      lastTime = timeS;
      grabCtx.drawImage(video, 0, 0, w, h);
      const image = grabCtx.getImageData(0, 0, w, h);
      const start = performance.now();
      const ticksBefore = ticks;
      busy = true;
      inFlight = tracker.track(image, timeS).then((done) => {
        busy = false;
        const ms = performance.now() - start;
        demo.frameMs.push(ms);
        if (ticks > ticksBefore) demo.framesTicked += 1;
        for (const frame of done) {
          records.push(frame);
          demo.frames += 1;
          const n = frame.hands.filter((hand) => hand.joints_3d_mm).length;
          demo.hands3d += n;
          if (n > 0) demo.framesWithHand3d += 1;
        }
        if (stopped) return;
        // The frame tracked (no other was read meanwhile), with its hands.
        ctx.drawImage(grab, 0, 0);
        if (done.length) {
          drawOverlay(ctx, done[done.length - 1]);
          if (handView && handView.update(done[done.length - 1]) > 0) demo.hand3dFrames += 1;
          if (handView?.bones) {
            demo.webxrBones = { ...handView.bones };
            demo.webxrMaxBoneOffsetMm = handView.maxBoneOffsetMm;
          }
        }
        recent.push(performance.now());
        while (recent.length > 30) recent.shift();
        const fps = recent.length > 1 ? (1000 * (recent.length - 1)) / (recent[recent.length - 1] - recent[0]) : 0;
        $('stats').textContent = `${fps.toFixed(1)} fps (tracking ${ms.toFixed(0)} ms a frame), `
          + `${demo.frames} frames, ${demo.framesWithHand3d} with a hand in 3D`
          + (!live && video.playbackRate < 1 ? `, playing at ${video.playbackRate.toFixed(2)}x` : '');
        $('download').disabled = records.length === 0;
        if (demo.frames === 1) showNotes();
      }, (e) => {
        busy = false;
        stop();
        say(`Tracking failed: ${e.message}`, { error: true });
      });
    }
    schedule();
  };
  const schedule = () => {
    if (stopped) return;
    if (video.requestVideoFrameCallback) video.requestVideoFrameCallback(step);
    else requestAnimationFrame(step);
  };
  const finish = async () => {
    if (stopped) return;
    stopped = true;
    $('stop').disabled = true;
    // The frame in the worker's hands first, then the frames it kept back.
    await inFlight;
    for (const frame of await tracker.finish()) records.push(frame);
    demo.state = 'stopped';
    say(`${label}: done, ${demo.frames} frames tracked.`);
  };
  const stop = () => {
    finish();
    video.pause();
    for (const track of video.srcObject?.getTracks?.() ?? []) track.stop();
  };
  video.addEventListener('ended', () => { if (!live) finish(); }, { once: true });
  demo.state = 'running';
  $('stop').disabled = false;
  say(`${label}: tracking.`);
  schedule();
  return { stop };
}

/** The records so far as JSON Lines (docs/output-format.md), one frame a line. */
function download() {
  const text = records.map((r) => JSON.stringify(r)).join('\n') + '\n';
  const a = document.createElement('a');
  a.href = URL.createObjectURL(new Blob([text], { type: 'application/x-ndjson' }));
  a.download = 'monohand-hands.jsonl';
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(a.href), 10000);
}

async function startTracker() {
  // A new session for each source: identities and the fit's warm start begin afresh.
  tracker?.close();
  tracker = null;
  const view3d = $('view3d').value;
  tracker = await createTracker({
    weights: params.get('weights') ?? './weights/',
    mirrorPass: $('mirror').checked,
    // The WebXR view poses its hand from the records' OpenXR joints.
    xrJoints: view3d === 'webxr',
  });
  demo.mirrorPass = $('mirror').checked;
  await showHandView(view3d);
  demo.threads = tracker.threads;
}

// The 3D view, `kind` 'mesh' (monohand's skinned hand) or 'webxr' (three.js' WebXR hand),
// made anew when the kind changes (on the same canvas). It is an extra: without three.js
// or WebGL the page says why and goes on.
async function showHandView(kind) {
  if (handView && demo.view3d === kind) return;
  handView?.renderer.dispose();
  handView = null;
  demo.view3d = kind;
  try {
    if (kind === 'webxr') {
      const { WebXRHandView } = await import('./webxr-hand.js');
      handView = new WebXRHandView($('hand3d'));
    } else {
      const { HandView } = await import('./hand3d.js');
      handView = new HandView($('hand3d'));
    }
  } catch (e) {
    $('hand3d').hidden = true;
    demo.hand3d = `No 3D view: ${e.message}. It needs WebGL and three.js in web/node_modules `
      + '(npm ci in web/; scripts/web-serve.sh does it).';
    $('hand3d-note').textContent = demo.hand3d;
  }
}

async function startCamera() {
  running?.stop();
  resetRecords();
  if (!navigator.mediaDevices?.getUserMedia) {
    say('This browser gives no camera to this page: browsers allow the camera only to pages '
      + `served over https or from localhost (this page is ${location.origin}). Serve it from `
      + 'localhost (scripts/web-serve.sh), or open a video file.', { error: true });
    return;
  }
  say('asking for the camera...');
  let stream;
  try {
    stream = await navigator.mediaDevices.getUserMedia({
      video: { width: { ideal: 640 }, height: { ideal: 480 } }, audio: false,
    });
  } catch (e) {
    say(cameraMessage(e), { error: true });
    return;
  }
  const video = $('source');
  video.srcObject = stream;
  await video.play();
  await startTracker();
  running = trackVideo(video, { live: true, label: 'camera' });
}

async function openFile(file) {
  running?.stop();
  resetRecords();
  const video = $('source');
  video.srcObject = null;
  video.src = URL.createObjectURL(file);
  // The session first, so that tracking starts with the video's first frames.
  await startTracker();
  try {
    await video.play();
  } catch (e) {
    say(`This browser cannot play ${file.name} (${e.name}: ${e.message}). Try an MP4 (H.264) `
      + 'or WebM file.', { error: true });
    return;
  }
  if (!(video.videoWidth > 0)) {
    say(`${file.name} has no picture this browser can decode.`, { error: true });
    return;
  }
  running = trackVideo(video, { live: false, label: file.name });
}

async function main() {
  const unsupported = unsupportedReason();
  if (unsupported) {
    say(unsupported, { error: true });
    return;
  }
  try {
    await startTracker();
  } catch (e) {
    say(`The tracker could not start: ${e.message}`, { error: true });
    return;
  }
  demo.state = 'ready';
  say('Ready: start the camera or open a video file.');
  $('camera').onclick = () => startCamera().catch((e) => say(`The camera failed: ${e.message}`, { error: true }));
  $('stop').onclick = () => running?.stop();
  $('download').onclick = download;
  $('file').onchange = (event) => {
    const file = event.target.files?.[0];
    if (file) openFile(file).catch((e) => say(`The video failed: ${e.message}`, { error: true }));
  };
  if (params.get('start') === 'camera') await startCamera();
}

main().catch((e) => say(`The page failed: ${e.message}`, { error: true }));
