// monohand's tracker in a Web Worker (made by monohand.js; not for pages to load). The page
// posts requests `{id, op, ...}` and gets `{id, ok, result}` or `{id, ok: false, error}`
// back, one answer a request, in the order they came.
//
// The module: the threaded one (pkg-threads/: rayon's pool on Web Workers sharing its
// memory, so the mirror pass runs its two landmark passes side by side) when the page is
// cross-origin isolated and asked for more than one thread; else the one-thread module
// (pkg/), and a note says why once.

let tracker = null;
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

async function start({ palm, landmark, settings, threads }) {
  const notes = [];
  let used = 1;
  let pkg;
  if (threads > 1 && self.crossOriginIsolated) {
    pkg = await import('./pkg-threads/monohand_web.js');
    await pkg.default();
    await pkg.initThreadPool(threads);
    used = threads;
  } else {
    pkg = await import('./pkg/monohand_web.js');
    await pkg.default();
    if (threads > 1) {
      notes.push('monohand runs on one thread: this page is not cross-origin isolated (serve it '
        + 'with the headers Cross-Origin-Opener-Policy: same-origin and '
        + 'Cross-Origin-Embedder-Policy: require-corp), so the mirror pass reads its two crops '
        + 'one after the other.');
    }
  }
  tracker = new pkg.WebTracker(palm, landmark, settings);
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
