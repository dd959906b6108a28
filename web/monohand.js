// monohand in the browser: RGBA frames in, tracked absolute 3D hands out, as the records
// `monohand run` writes (docs/output-format.md), as plain objects.
//
//   import { createTracker } from './monohand.js';
//   const tracker = await createTracker({ weights: './weights/' });
//   const frames = tracker.track(ctx.getImageData(0, 0, w, h), video.currentTime);
//   for (const frame of frames) for (const hand of frame.hands) console.log(hand.joints_3d_mm);
//
// The WebAssembly module (pkg/, from scripts/web-build.sh) and the weights (weights/, copied
// by the same script from `monohand models fetch`'s cache) are served beside this file; no
// other network is used.

import init, { WebTracker } from './pkg/monohand_web.js';

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

/** A tracking session over the page's frames. Made by {@link createTracker}. */
export class Tracker {
  constructor(inner) {
    this.inner = inner;
  }

  /**
   * Tracks the hands of one frame: an `ImageData` (from a canvas that drew a `<video>`
   * frame, for one) at `timeS` seconds. Returns the records of the frames now done (this
   * one), each `{frame, time_s, image_size, cameras, hands: [{side, id, keypoints_2d,
   * joints_3d_mm, pose, ...}], timings_ms}`.
   */
  track(imageData, timeS) {
    const data = imageData.data;
    const rgba = new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
    return JSON.parse(this.inner.process(rgba, imageData.width, imageData.height, timeS));
  }

  /** The records of the frames still kept back (call once at the end of a video). */
  finish() {
    return JSON.parse(this.inner.finish());
  }

  /** Messages for the user since the last call (the camera assumed, for one). */
  notes() {
    return JSON.parse(this.inner.notes());
  }
}

/**
 * Loads the WebAssembly module and the networks and starts a session. Options: `weights`
 * (the folder URL of the weights, relative to the page; default: `weights/` beside this
 * file), `palm` and `landmark` (file names
 * in it, or `Uint8Array`s a user picked), `hands` (most hands, default 2), `detectEvery`
 * (default 10), `mirrorPass` (default true; false reads each crop once, as MediaPipe does:
 * about twice as fast, at a higher 3D error), `camera` (`{fx, fy, cx, cy, width, height}`; default: a generic 60 degree
 * camera for the frames' size). Rejects with a message that says what is wrong for an
 * unsupported browser ({@link unsupportedReason}), weights missing, cut short or of
 * another network, and bad options.
 */
export async function createTracker(options = {}) {
  const unsupported = unsupportedReason();
  if (unsupported) throw new Error(unsupported);
  await init();
  // Given: relative to the page. Default: the weights/ folder beside this file (so a copy
  // of the package served anywhere finds its own).
  const base = options.weights !== undefined ? new URL(options.weights, document.baseURI)
    : new URL('./weights/', import.meta.url);
  const load = async (which, what) => {
    const given = options[which] ?? DEFAULT_WEIGHTS[which];
    return given instanceof Uint8Array ? given : fetchBytes(new URL(given, base), what);
  };
  const [palm, landmark] = await Promise.all([
    load('palm', 'palm detector weights'),
    load('landmark', 'hand landmark weights'),
  ]);
  const settings = {};
  if (options.hands !== undefined) settings.hands = options.hands;
  if (options.detectEvery !== undefined) settings.detect_every = options.detectEvery;
  if (options.mirrorPass !== undefined) settings.mirror_pass = options.mirrorPass;
  if (options.camera !== undefined) settings.camera = options.camera;
  return new Tracker(new WebTracker(palm, landmark, JSON.stringify(settings)));
}
