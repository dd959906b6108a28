// monohand's tracker in a Web Worker (made by monohand.js; not for pages to load). The page
// posts requests `{id, op, ...}` and gets `{id, ok, result}` or `{id, ok: false, error}`
// back, one answer a request, in the order they came.
//
// The module: the threaded one (pkg-threads/: rayon's pool on Web Workers sharing its
// memory, so the mirror pass runs its two landmark passes side by side; built with relaxed
// SIMD too, for its fused multiply-adds and int8 dot products) when the page is cross-origin
// isolated, asked for more than one thread and the browser has relaxed SIMD; else the
// one-thread module (pkg/, plain simd128), and a note says why once.

let tracker = null;
let module = null; // the module's exports (pkg/ or pkg-threads/)
let scratch = null; // an OffscreenCanvas to read an ImageBitmap's or VideoFrame's pixels
let pending = Promise.resolve();

/** The RGBA bytes of a frame the page sent: `{rgba, width, height}` or a bitmap/video frame. */
function pixels(frame) {
  if (frame.rgba) return frame;
  const source = frame.image;
  const width = source.displayWidth ?? source.width;
  const height = source.displayHeight ?? source.height;
  if (!scratch || scratch.canvas.width !== width || scratch.canvas.height !== height) {
    const canvas = new OffscreenCanvas(width, height);
    scratch = canvas.getContext('2d', { willReadFrequently: true });
  }
  scratch.drawImage(source, 0, 0);
  source.close?.();
  const data = scratch.getImageData(0, 0, width, height).data;
  return { rgba: new Uint8Array(data.buffer, data.byteOffset, data.byteLength), width, height };
}

// The smallest module with a relaxed SIMD instruction (two i8x16.splat of 0, then
// i8x16.relaxed_swizzle): a browser that validates it can run the threaded module (Chrome
// and Edge from 114; other engines as they ship the proposal).
const RELAXED_SIMD_PROBE = new Uint8Array([0, 97, 115, 109, 1, 0, 0, 0, 1, 5, 1, 96, 0, 1, 123,
  3, 2, 1, 0, 10, 15, 1, 13, 0, 65, 0, 253, 15, 65, 0, 253, 15, 253, 128, 2, 11]);

async function start({ palm, landmark, settings, threads }) {
  const notes = [];
  let used = 1;
  let pkg;
  const relaxed = WebAssembly.validate(RELAXED_SIMD_PROBE);
  if (threads > 1 && self.crossOriginIsolated && relaxed) {
    pkg = await import('./pkg-threads/monohand_web.js');
    await pkg.default();
    // rayon's pool: `threads` Web Workers for the mirror pass's two landmark runs, and
    // `threads - 1` more, each kept by a helper of the operator team, which shares one
    // network's large operators between this thread and the helpers (like for like: one
    // network at a time). Idle helpers sleep.
    await pkg.initThreadPool(2 * threads - 1);
    pkg.startOperatorTeam(threads);
    used = threads;
  } else {
    pkg = await import('./pkg/monohand_web.js');
    await pkg.default();
    if (threads > 1 && !self.crossOriginIsolated) {
      notes.push('monohand runs on one thread: this page is not cross-origin isolated (serve it '
        + 'with the headers Cross-Origin-Opener-Policy: same-origin and '
        + 'Cross-Origin-Embedder-Policy: require-corp), so the mirror pass reads its two crops '
        + 'one after the other.');
    } else if (threads > 1) {
      notes.push('monohand runs on one thread: this browser has no WebAssembly relaxed SIMD, '
        + 'which the threaded module is built with, so the mirror pass reads its two crops one '
        + 'after the other.');
    }
  }
  tracker = new pkg.WebTracker(palm, landmark, settings);
  module = pkg;
  return { threads: used, notes };
}

function handle(request) {
  switch (request.op) {
    case 'start':
      return start(request);
    case 'track': {
      const { rgba, width, height } = pixels(request.frame);
      return tracker.process(rgba, width, height, request.timeS);
    }
    case 'finish':
      return tracker.finish();
    case 'notes':
      return tracker.notes();
    case 'sharedOperators':
      return module.sharedOperators();
    default:
      throw new Error(`unknown request ${request.op}`);
  }
}

self.onmessage = ({ data }) => {
  pending = pending.then(async () => {
    try {
      self.postMessage({ id: data.id, ok: true, result: await handle(data) });
    } catch (e) {
      self.postMessage({ id: data.id, ok: false, error: String(e?.message ?? e) });
    }
  });
};
