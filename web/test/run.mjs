// Drives the frame-exact browser test: serves web/ and the clip on 127.0.0.1 only, opens the
// test page (web/test/index.html) in headless Chromium, reads the page's result over the
// DevTools protocol, writes the records as JSON Lines and a screenshot, and prints the
// timings as JSON on its last line.
//
//   node --experimental-websocket run.mjs --web DIR --clip FILE.rgba --size WxH --fps N \
//        --out records.jsonl --screenshot shot.png [--isolated 0] [--bitmap] [--precision int8]
//        [--chromium PATH] [--timeout SECS]
//
// `--isolated 0` serves the page without the cross-origin isolation headers: the tracker
// then runs on one thread (and its notes say so). `--bitmap` hands the page's frames to the
// tracker as ImageBitmaps instead of ImageData. `--precision int8` runs the networks' 1x1
// convolutions in int8 (the tracker's `precision` option).

import { writeFileSync } from 'node:fs';
import { launch, parseArgs, serve } from './chromium.mjs';

const args = parseArgs();
for (const need of ['web', 'clip', 'size', 'out']) {
  if (!args[need]) throw new Error(`--${need} is required`);
}
const [w, h] = args.size.split('x').map(Number);
const timeoutS = Number(args.timeout ?? 900);

const server = await serve({
  mounts: { '/': args.web }, files: { '/clip.rgba': args.clip }, isolated: args.isolated !== '0',
});
let browser = null;
try {
  browser = await launch({ chromium: args.chromium });
  const url = `http://127.0.0.1:${server.port}/test/index.html?clip=/clip.rgba&w=${w}&h=${h}&fps=${args.fps ?? 30}${'bitmap' in args ? '&bitmap=1' : ''}${args.precision ? `&precision=${args.precision}` : ''}`;
  await browser.send('Page.navigate', { url });
  const result = await browser.waitFor(
    'window.monohandResult ? JSON.stringify(window.monohandResult) : null', timeoutS);
  if (result.error) throw new Error(`the page failed: ${result.error}`);
  writeFileSync(args.out, result.records.map((r) => JSON.stringify(r)).join('\n') + '\n');
  if (args.screenshot) writeFileSync(args.screenshot, await browser.screenshot());
  const ms = result.frameMs;
  const after = ms.slice(1);
  const mean = (a) => a.reduce((s, x) => s + x, 0) / Math.max(1, a.length);
  const sorted = [...after].sort((a, b) => a - b);
  console.log(JSON.stringify({
    frames: ms.length,
    load_ms: result.loadMs,
    first_frame_ms: result.firstFrameMs,
    mean_ms_after_first: mean(after),
    median_ms_after_first: sorted[Math.floor(sorted.length / 2)] ?? null,
    notes: result.notes,
    threads: result.threads,
    shared_operators: result.sharedOperators,
    hardware_concurrency: result.hardwareConcurrency,
    user_agent: result.userAgent,
  }));
} finally {
  await browser?.close();
  server.close();
}
