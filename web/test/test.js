// The browser test's page (scripts/web-test.sh): runs the tracker on the raw RGBA frames of
// a clip (one file, frames one after the other, as ffmpeg's `-f rawvideo -pix_fmt rgba`
// writes them), draws the last frame with the demo page's overlay (../overlay.js), and leaves the records and the
// timings in `window.monohandResult` for the driver (run.mjs) to read.
// URL parameters: clip (the .rgba file), w, h, fps, weights (their folder; default ../weights/),
// bitmap (1: the frames as ImageBitmaps), precision (f32, the default, or int8).

import { createTracker } from '../monohand.js';
import { drawOverlay } from '../overlay.js';
import { readClip } from './clip.js';

const status = document.getElementById('status');
const say = (text) => { status.textContent = text; };

function draw(image, frame) {
  const canvas = document.getElementById('view');
  canvas.width = image.width;
  canvas.height = image.height;
  const ctx = canvas.getContext('2d');
  ctx.putImageData(image, 0, 0);
  if (frame) drawOverlay(ctx, frame);
}

async function main() {
  const params = new URLSearchParams(location.search);
  const w = Number(params.get('w'));
  const h = Number(params.get('h'));
  const fps = Number(params.get('fps') ?? 30);
  const bitmap = params.get('bitmap') === '1';
  const t0 = performance.now();
  const tracker = await createTracker({
    weights: params.get('weights') ?? '../weights/',
    precision: params.get('precision') ?? 'f32',
    // The records with their OpenXR joints, compared with native `run --xr-joints`'s.
    xrJoints: true,
  });
  const loadMs = performance.now() - t0;
  say('networks loaded; reading the clip...');
  const clip = await readClip(params.get('clip'), w, h);
  const n = clip.n;
  const records = [];
  const frameMs = [];
  let image = null;
  for (let i = 0; i < n; i++) {
    image = clip.frame(i);
    // `bitmap=1`: each frame handed over as an ImageBitmap (transferred; the worker reads
    // its pixels through an OffscreenCanvas) instead of copied as ImageData.
    const frame = bitmap ? await createImageBitmap(image) : image;
    const t = performance.now();
    records.push(...await tracker.track(frame, i / fps));
    frameMs.push(performance.now() - t);
    say(`frame ${i + 1} of ${n}`);
    // Let the page draw between frames.
    await new Promise((resolve) => setTimeout(resolve, 0));
  }
  records.push(...await tracker.finish());
  draw(image, records[records.length - 1]);
  const notes = await tracker.notes();
  const sharedOperators = await tracker.sharedOperators();
  const { threads } = tracker;
  tracker.close();
  say(`${n} frames; ${notes.join('; ')}`);
  return { records, frameMs, loadMs, firstFrameMs: loadMs + frameMs[0], notes, threads, sharedOperators,
    hardwareConcurrency: navigator.hardwareConcurrency, userAgent: navigator.userAgent };
}

main().then(
  (result) => { window.monohandResult = result; },
  (error) => {
    say(`error: ${error.message}`);
    window.monohandResult = { error: String(error.message ?? error) };
  },
);
