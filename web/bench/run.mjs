// Runs the side-by-side benchmark page (web/bench/index.html) in headless Chromium on a
// raw RGBA clip and prints its result as JSON on the last line, with the MediaPipe files the
// page fetched (to show which of their WebAssembly builds ran).
//
//   node --experimental-websocket web/bench/run.mjs --web web --clip FILE.rgba --size WxH \
//        [--fps 30] [--rounds 2] [--legacy-frames N] [--weights DIR] [--chromium PATH]
//        [--timeout SECS]
//
// --legacy-frames N: @mediapipe/hands (the legacy solution, on WebGL, software-rendered
// without a GPU: about 2 s a frame) runs only the clip's first N frames (default: all).
//
// MediaPipe Tasks' HandLandmarker takes its networks as one model bundle (a `.task` file),
// which is not on npm: it is a zip of `hand_detector.tflite` and
// `hand_landmarks_detector.tflite`, so it is written here from the weights monohand runs
// (--weights, default WEB/weights: palm_detection_full.tflite and hand_landmark_full.tflite,
// MediaPipe 0.10.14's, from `monohand models fetch`'s cache) into a temporary folder,
// served to the page as /hand_landmarker.task and removed at the end.

import { mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { launch, parseArgs, serve } from '../test/chromium.mjs';

const CRC_TABLE = Array.from({ length: 256 }, (_, n) => {
  let c = n;
  for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
  return c >>> 0;
});

function crc32(bytes) {
  let c = 0xffffffff;
  for (const b of bytes) c = CRC_TABLE[(c ^ b) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
}

/**
 * A zip of `files` (`[[name, bytes], ...]`), stored (not compressed; MediaPipe reads the
 * networks in place), each file's bytes starting at a multiple of 64 (padding in the local
 * header's extra field), without zip64: each file and the whole under 4 GB.
 */
export function storedZip(files) {
  const parts = [];
  const central = [];
  let offset = 0;
  for (const [name, bytes] of files) {
    const nameBytes = Buffer.from(name, 'utf8');
    const crc = crc32(bytes);
    const pad = (64 - ((offset + 30 + nameBytes.length) % 64)) % 64;
    const extra = Buffer.alloc(pad < 4 && pad > 0 ? pad + 64 : pad);
    if (extra.length) extra.writeUInt16LE(0xd935, 0), extra.writeUInt16LE(extra.length - 4, 2);
    const local = Buffer.alloc(30);
    local.writeUInt32LE(0x04034b50, 0);
    local.writeUInt16LE(10, 4); // version needed: 1.0
    local.writeUInt16LE(0x0800, 6); // flags: UTF-8 names
    local.writeUInt16LE(0, 8); // method: stored
    local.writeUInt16LE(0, 10); // time
    local.writeUInt16LE(0x21, 12); // date: 1980-01-01
    local.writeUInt32LE(crc, 14);
    local.writeUInt32LE(bytes.length, 18);
    local.writeUInt32LE(bytes.length, 22);
    local.writeUInt16LE(nameBytes.length, 26);
    local.writeUInt16LE(extra.length, 28);
    const entry = Buffer.alloc(46);
    entry.writeUInt32LE(0x02014b50, 0);
    entry.writeUInt16LE(10, 4); // made by
    entry.writeUInt16LE(10, 6);
    entry.writeUInt16LE(0x0800, 8);
    entry.writeUInt16LE(0, 10);
    entry.writeUInt16LE(0, 12);
    entry.writeUInt16LE(0x21, 14);
    entry.writeUInt32LE(crc, 16);
    entry.writeUInt32LE(bytes.length, 20);
    entry.writeUInt32LE(bytes.length, 24);
    entry.writeUInt16LE(nameBytes.length, 28);
    entry.writeUInt32LE(offset, 42); // the local header's offset (extra, comment, attributes: 0)
    central.push(entry, nameBytes);
    parts.push(local, nameBytes, extra, bytes);
    offset += local.length + nameBytes.length + extra.length + bytes.length;
  }
  const centralSize = central.reduce((s, b) => s + b.length, 0);
  const end = Buffer.alloc(22);
  end.writeUInt32LE(0x06054b50, 0);
  end.writeUInt16LE(files.length, 8);
  end.writeUInt16LE(files.length, 10);
  end.writeUInt32LE(centralSize, 12);
  end.writeUInt32LE(offset, 16);
  return Buffer.concat([...parts, ...central, end]);
}

const args = parseArgs();
for (const need of ['web', 'clip', 'size']) {
  if (!args[need]) throw new Error(`--${need} is required`);
}
const [w, h] = args.size.split('x').map(Number);
const weights = args.weights ?? join(args.web, 'weights');
const taskDir = mkdtempSync(join(tmpdir(), 'monohand-web-bench-'));
const taskFile = join(taskDir, 'hand_landmarker.task');
writeFileSync(taskFile, storedZip([
  ['hand_detector.tflite', readFileSync(join(weights, 'palm_detection_full.tflite'))],
  ['hand_landmarks_detector.tflite', readFileSync(join(weights, 'hand_landmark_full.tflite'))],
]));
const fetched = [];
let server = null;
let browser = null;
try {
  server = await serve({
    mounts: { '/': args.web },
    files: { '/clip.rgba': args.clip, '/hand_landmarker.task': taskFile },
    onRequest: (path) => fetched.push(path),
  });
  // MediaPipe's legacy solution runs its graph on WebGL (HandLandmarkTrackingGpu): WebGL is
  // left on (no --disable-gpu). Without a GPU, Chromium renders it in software (the page
  // reports the renderer).
  browser = await launch({ chromium: args.chromium, webgl: true });
  const url = `http://127.0.0.1:${server.port}/bench/index.html?clip=/clip.rgba&w=${w}&h=${h}`
    + `&fps=${args.fps ?? 30}&rounds=${args.rounds ?? 2}&task=/hand_landmarker.task`
    + `&legacy_frames=${args['legacy-frames'] ?? 0}`;
  await browser.send('Page.navigate', { url });
  const result = await browser.waitFor('window.benchResult ? JSON.stringify(window.benchResult) : null',
    Number(args.timeout ?? 900), 'the benchmark page');
  if (result.error) throw new Error(`the benchmark page failed: ${result.error}`);
  const files = (pkg) => [...new Set(fetched.filter((p) => p.includes(`/${pkg}/`)).map((p) => p.split('/').pop()))];
  result.mediapipe.files = files('@mediapipe/hands');
  result.tasks.files = [...files('@mediapipe/tasks-vision'),
    ...(fetched.includes('/hand_landmarker.task') ? ['hand_landmarker.task'] : [])];
  console.log(JSON.stringify(result));
} finally {
  await browser?.close();
  server?.close();
  rmSync(taskDir, { recursive: true, force: true });
}
