// Runs the side-by-side benchmark page (web/bench/index.html) in headless Chromium on a
// raw RGBA clip and prints its result as JSON on the last line, with the MediaPipe files the
// page fetched (to show which of its WebAssembly builds ran).
//
//   node --experimental-websocket web/bench/run.mjs --web web --clip FILE.rgba --size WxH \
//        [--fps 30] [--rounds 2] [--chromium PATH] [--timeout SECS]

import { launch, parseArgs, serve } from '../test/chromium.mjs';

const args = parseArgs();
for (const need of ['web', 'clip', 'size']) {
  if (!args[need]) throw new Error(`--${need} is required`);
}
const [w, h] = args.size.split('x').map(Number);
const fetched = [];
const server = await serve({
  mounts: { '/': args.web },
  files: { '/clip.rgba': args.clip },
  onRequest: (path) => fetched.push(path),
});
let browser = null;
try {
  // MediaPipe's legacy solution runs its graph on WebGL (HandLandmarkTrackingGpu): WebGL is
  // left on (no --disable-gpu). Without a GPU, Chromium renders it in software (the page
  // reports the renderer).
  browser = await launch({ chromium: args.chromium, webgl: true });
  const url = `http://127.0.0.1:${server.port}/bench/index.html?clip=/clip.rgba&w=${w}&h=${h}&fps=${args.fps ?? 30}&rounds=${args.rounds ?? 2}`;
  await browser.send('Page.navigate', { url });
  const result = await browser.waitFor('window.benchResult ? JSON.stringify(window.benchResult) : null',
    Number(args.timeout ?? 900), 'the benchmark page');
  if (result.error) throw new Error(`the benchmark page failed: ${result.error}`);
  result.mediapipe.files = [...new Set(fetched.filter((p) => p.includes('@mediapipe')).map((p) => p.split('/').pop()))];
  console.log(JSON.stringify(result));
} finally {
  browser?.close();
  server.close();
}
