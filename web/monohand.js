// monohand in the browser: RGBA frames in, tracked absolute 3D hands out, as the records
// `monohand run` writes (docs/output-format.md), as plain objects.
//
//   import { createTracker } from './monohand.js';
//   const tracker = await createTracker({ weights: './weights/' });
//   const frames = await tracker.track(ctx.getImageData(0, 0, w, h), video.currentTime);
//   for (const frame of frames) for (const hand of frame.hands) console.log(hand.joints_3d_mm);
//
// The tracker runs in a Web Worker (worker.js), so the page's own thread stays free while
// it works. The WebAssembly modules (pkg/, and pkg-threads/ for cross-origin isolated
// pages in browsers with relaxed SIMD, from scripts/web-build.sh) and the weights (weights/, copied by the same script
// from `monohand models fetch`'s cache) are served beside this file; no other network is
// used.

export { WEBXR_JOINT_NAMES, webxrJoints, webxrJointName } from './webxr.js';

/** The weights files the tracker loads by default (MediaPipe 0.10.14's full networks). */
export const DEFAULT_WEIGHTS = {
  palm: 'palm_detection_full.tflite',
  landmark: 'hand_landmark_full.tflite',
};

// The smallest module with a SIMD instruction (v128.const, i32x4 add; as wasm-feature-detect
// has it): a browser that validates it runs the module's simd128 code.
const SIMD_PROBE = new Uint8Array([0, 97, 115, 109, 1, 0, 0, 0, 1, 5, 1, 96, 0, 1, 123, 3, 2, 1,
  0, 10, 10, 1, 8, 0, 65, 0, 253, 15, 253, 98, 11]);

/**
 * Why this browser cannot run monohand, or `null` if it can: it needs WebAssembly with
 * SIMD (Chrome and Edge 91, Firefox 89, Safari 16.4 or newer).
 */
export function unsupportedReason() {
  if (typeof WebAssembly !== 'object' || typeof WebAssembly.validate !== 'function') {
    return 'This browser cannot run WebAssembly (or it is turned off), which monohand needs: '
      + 'use a current Chrome, Edge, Firefox or Safari.';
  }
  if (!WebAssembly.validate(SIMD_PROBE)) {
    return 'This browser runs WebAssembly without SIMD, which monohand\'s networks need: use '
      + 'Chrome or Edge 91, Firefox 89, Safari 16.4 or newer.';
  }
  return null;
}

async function fetchBytes(url, what) {
  let response;
  try {
    response = await fetch(url);
  } catch (e) {
    throw new Error(`cannot fetch the ${what} from ${url}: ${e.message}`);
  }
  if (!response.ok) {
    throw new Error(`cannot fetch the ${what} from ${url}: HTTP ${response.status} ${response.statusText}`);
  }
  return new Uint8Array(await response.arrayBuffer());
}

/** A tracking session over the page's frames, run in a Web Worker. Made by {@link createTracker}. */
export class Tracker {
  constructor(worker, threads, notes) {
    this.worker = worker;
    /** The threads the tracker runs on (1 unless the page is cross-origin isolated and the browser has relaxed SIMD). */
    this.threads = threads;
    this.startNotes = notes;
    this.nextId = 0;
    this.waiting = new Map();
    worker.onmessage = ({ data }) => {
      const w = this.waiting.get(data.id);
      this.waiting.delete(data.id);
      if (data.ok) w?.resolve(data.result);
      else w?.reject(new Error(data.error));
    };
    worker.onerror = (event) => this.failAll(`the tracker's worker failed: ${event.message ?? 'no message'}`);
  }

  /** Posts a request to the worker; resolves with its answer. */
  call(request, transfer = []) {
    if (!this.worker) return Promise.reject(new Error('the tracker is closed'));
    const id = this.nextId++;
    return new Promise((resolve, reject) => {
      this.waiting.set(id, { resolve, reject });
      this.worker.postMessage({ ...request, id }, transfer);
    });
  }

  failAll(message) {
    for (const w of this.waiting.values()) w.reject(new Error(message));
    this.waiting.clear();
  }

  /**
   * Tracks the hands of one frame at `timeS` seconds: an `ImageData` (from a canvas that
   * drew a `<video>` frame, for one; its pixels are copied), or an `ImageBitmap` or
   * `VideoFrame` (handed over to the worker, which closes it). Resolves with the records of
   * the frames now done (this one), each `{frame, time_s, image_size, cameras, hands:
   * [{side, id, keypoints_2d, joints_3d_mm, pose, ...}], timings_ms}`. The page's thread is
   * free meanwhile; calls are answered in order.
   */
  async track(frame, timeS) {
    let message;
    let transfer = [];
    if (typeof ImageData !== 'undefined' && frame instanceof ImageData) {
      // A copy of exactly the frame's bytes, handed over. (Posting `frame.data` itself would
      // clone the whole buffer it views, which may be far larger than the frame.)
      const rgba = frame.data.slice();
      message = { rgba, width: frame.width, height: frame.height };
      transfer = [rgba.buffer];
    } else {
      message = { image: frame };
      transfer = [frame];
    }
    return JSON.parse(await this.call({ op: 'track', frame: message, timeS }, transfer));
  }

  /** The records of the frames still kept back (call once at the end of a video). */
  async finish() {
    return JSON.parse(await this.call({ op: 'finish' }));
  }

  /** Messages for the user since the last call (the camera assumed, for one). */
  async notes() {
    const notes = [...this.startNotes, ...JSON.parse(await this.call({ op: 'notes' }))];
    this.startNotes = [];
    return notes;
  }

  /**
   * How many operator evaluations have been shared between threads so far: on two threads
   * a network that runs alone (one hand tracked without the mirror pass, or the detector
   * alone) shares its large operators between both; 0 on one thread. A diagnostic.
   */
  async sharedOperators() {
    return this.call({ op: 'sharedOperators' });
  }

  /** Stops the worker (and its threads); the tracker cannot be used after. */
  close() {
    this.worker?.terminate();
    this.worker = null;
    this.failAll('the tracker was closed');
  }
}

/**
 * Loads the WebAssembly module and the networks and starts a session in a Web Worker.
 * Options: `weights` (the folder URL of the weights, relative to the page; default:
 * `weights/` beside this file), `palm` and `landmark` (file names in it, or `Uint8Array`s
 * a user picked), `hands` (most hands, default 2), `detectEvery` (default 10), `mirrorPass`
 * (default true; false reads each crop once, as MediaPipe does: about twice as fast, at a
 * higher 3D error), `camera` (`{fx, fy, cx, cy, width, height}`; default: a generic 60
 * degree camera for the frames' size), `threads` (default: 2, or 1 on a one-core machine;
 * more than one needs a cross-origin isolated page and WebAssembly relaxed SIMD, else it
 * runs on one and a note says why), `precision` ('f32', the default, or 'int8': fast where
 * it runs threaded), `hand` (a hand file's object, from `monohand run --save-hand`: both
 * hands at the person's size) or `handLengthMm` (a ruler's hand length), `xrJoints` (default
 * false; true: each fitted hand's record carries its 26 OpenXR joints, `xr_joints`, as
 * `monohand run --xr-joints`, which {@link webxrJoints} turns into WebXR's 25). Rejects with a message that says what is wrong for an unsupported browser
 * ({@link unsupportedReason}), weights missing, cut short or of another network, and bad
 * options.
 */
export async function createTracker(options = {}) {
  const unsupported = unsupportedReason();
  if (unsupported) throw new Error(unsupported);
  // Given: relative to the page. Default: the weights/ folder beside this file (so a copy
  // of the package served anywhere finds its own).
  const base = options.weights !== undefined ? new URL(options.weights, document.baseURI)
    : new URL('./weights/', import.meta.url);
  const load = async (which, what) => {
    const given = options[which] ?? DEFAULT_WEIGHTS[which];
    return given instanceof Uint8Array ? given : fetchBytes(new URL(given, base), what);
  };
  // Both fetched at once, awaited in order: where both fail (a folder without them), the
  // error names the palm detector's whichever answered first (Promise.all reported the
  // first to fail in time, which made the message, and the web test, depend on timing).
  const palmBytes = load('palm', 'palm detector weights');
  const landmarkBytes = load('landmark', 'hand landmark weights');
  landmarkBytes.catch(() => {}); // handled below, after the palm detector's
  const palm = await palmBytes;
  const landmark = await landmarkBytes;
  const settings = {};
  if (options.hands !== undefined) settings.hands = options.hands;
  if (options.detectEvery !== undefined) settings.detect_every = options.detectEvery;
  if (options.mirrorPass !== undefined) settings.mirror_pass = options.mirrorPass;
  if (options.precision !== undefined) settings.precision = options.precision;
  if (options.camera !== undefined) settings.camera = options.camera;
  if (options.hand !== undefined) settings.hand = options.hand;
  if (options.handLengthMm !== undefined) settings.hand_length_mm = options.handLengthMm;
  if (options.xrJoints !== undefined) settings.xr_joints = options.xrJoints;
  const threads = options.threads ?? Math.min(navigator.hardwareConcurrency || 1, 2);
  const worker = new Worker(new URL('./worker.js', import.meta.url), { type: 'module' });
  const tracker = new Tracker(worker, 1, []);
  try {
    const started = await tracker.call({
      op: 'start', palm, landmark, settings: JSON.stringify(settings), threads,
    });
    tracker.threads = started.threads;
    tracker.startNotes = started.notes;
  } catch (e) {
    tracker.close();
    throw e;
  }
  return tracker;
}
