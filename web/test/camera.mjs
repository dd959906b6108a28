// Drives the camera test: the demo page (web/index.html?start=camera) in headless Chromium
// with a fake camera that plays a .y4m clip (`--use-fake-device-for-media-stream
// --use-file-for-fake-video-capture`), until the page has tracked `--frames` frames of the
// camera stream; writes a screenshot of the overlay and prints the page's counts as JSON on
// its last line. Exits 1 if the page failed, found a hand in 3D in fewer than half of them,
// its three.js view (web/hand3d.js) drew no hand, or its own timer did not tick while the
// tracker worked (in a Web Worker) on at least half of the frames: a tracker on the page's
// thread would block it in every one.
//
// With `--expect-error TEXT` the page must fail to open the camera with a message that
// contains TEXT, and track nothing: with `--deny`, the camera's permission denied
// (DevTools' Browser.setPermission); with `--no-device`, no fake camera (a machine
// without one); with bad weights (`--extra`, `--query`) or `--js-flags=--jitless` (a
// browser without WebAssembly), the tracker cannot start.
//
//   node --experimental-websocket camera.mjs --web DIR --y4m clip.y4m --frames N \
//        --screenshot shot.png [--download records.jsonl] [--chromium PATH] [--timeout SECS]
//        [--extra DIR (served as /extra/)] [--query '&weights=/extra/' (added to the URL)]
//        [--js-flags FLAGS (V8's, e.g. --jitless: no WebAssembly)] [--every-frame (a hand in 3D
//        in every frame tracked, not only in most)]
//   node --experimental-websocket camera.mjs --web DIR (--deny | --no-device) --expect-error TEXT [...]
//
// `--video FILE` opens a video file with the page's file input (DevTools'
// DOM.setFileInputFiles) instead of the camera, and waits for its end; with
// `--expect-error` the page must refuse it with that message.
//
// `--download` presses the page's download button and checks the JSON Lines it gives: the
// frames in order, at least as many as the page had tracked.

import { existsSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';
import { launch, parseArgs, serve } from './chromium.mjs';

const args = parseArgs();
if (!args.web) throw new Error('--web is required');
const deny = 'deny' in args;
const expectError = 'expect-error' in args;
if (!expectError && !args.y4m && !args.video) throw new Error('--y4m or --video is required (or --expect-error)');
const frames = Number(args.frames ?? 30);
const timeoutS = Number(args.timeout ?? 600);

const mounts = { '/': args.web };
if (args.extra) mounts['/extra/'] = args.extra;
const server = await serve({ mounts });
let browser = null;
try {
  // The fake camera; its permission is granted (the fake UI accepts) unless --deny.
  // With --no-device, no camera at all (the machine's, which a test machine has none of).
  const flags = [];
  if (!('no-device' in args)) flags.push('--use-fake-device-for-media-stream');
  if (args.y4m) flags.push(`--use-file-for-fake-video-capture=${args.y4m}`);
  if (!deny) flags.push('--use-fake-ui-for-media-stream');
  if (args['js-flags']) flags.push(`--js-flags=${args['js-flags']}`);
  // WebGL (software) for the demo's three.js view.
  browser = await launch({ chromium: args.chromium, flags, webgl: true });
  const origin = `http://127.0.0.1:${server.port}`;
  if (deny) {
    await browser.send('Browser.setPermission', {
      permission: { name: 'camera' }, setting: 'denied', origin,
    });
  }
  // A video file instead of the camera: opened with the page's file input, as a user does.
  const video = args.video ? resolve(args.video) : null;
  await browser.send('Page.navigate', { url: `${origin}/index.html?${video ? '' : 'start=camera'}${args.query ?? ''}` });
  if (video) {
    await browser.waitFor(`(d => d && (d.state === 'ready' || d.state === 'error') ? '1' : null)(window.monohandDemo)`,
      timeoutS, 'the demo page (ready)');
    const { root } = await browser.send('DOM.getDocument');
    const { nodeId } = await browser.send('DOM.querySelector', { nodeId: root.nodeId, selector: '#file' });
    await browser.send('DOM.setFileInputFiles', { files: [video], nodeId });
  }
  const state = 'JSON.stringify(window.monohandDemo ?? null)';
  if (expectError) {
    const demo = await browser.waitFor(
      `(d => d && d.state === 'error' ? JSON.stringify({ ...d, shown: document.getElementById('message').textContent }) : null)(window.monohandDemo)`,
      timeoutS, 'the page (expecting its message)');
    if (!demo.shown.includes(args['expect-error'] ?? '')) {
      throw new Error(`expected the page to say "${args['expect-error']}", it says ${JSON.stringify(demo.shown)}`);
    }
    if (demo.frames !== 0) throw new Error(`the page failed, yet ${demo.frames} frames were tracked`);
    if (args.screenshot) writeFileSync(args.screenshot, await browser.screenshot());
    console.log(JSON.stringify({ message: demo.shown }));
  } else {
    const demo = await browser.waitFor(
      `(d => d && (d.state === 'error' || ${video ? "d.state === 'stopped'" : `d.frames >= ${frames}`}) ? ${state} : null)(window.monohandDemo)`,
      timeoutS, video ? 'the demo page (to the end of the video)' : `the demo page (${frames} camera frames)`);
    if (demo.state === 'error') throw new Error(`the page failed: ${demo.message}`);
    // The screenshot: the frame last tracked, with its overlay.
    if (args.screenshot) writeFileSync(args.screenshot, await browser.screenshot());
    const ms = [...demo.frameMs].slice(1).sort((a, b) => a - b);
    const result = {
      frames: demo.frames,
      frames_with_hand_3d: demo.framesWithHand3d,
      hands_3d: demo.hands3d,
      hand3d_view_frames: demo.hand3dFrames,
      median_ms_after_first: ms[Math.floor(ms.length / 2)] ?? null,
      mirror_pass: demo.mirrorPass,
      view3d: demo.view3d,
      webxr_bones: demo.webxrBones,
      webxr_max_bone_offset_mm: demo.webxrMaxBoneOffsetMm,
      threads: demo.threads,
      track_calls: demo.frameMs.length,
      frames_ticked: demo.framesTicked,
      message: demo.message,
    };
    if (args.download) {
      // The page's download button: the records so far as JSON Lines, one frame a line.
      const dir = mkdtempSync(join(tmpdir(), 'monohand-web-download-'));
      await browser.send('Browser.setDownloadBehavior', { behavior: 'allow', downloadPath: dir });
      await browser.evaluate("document.getElementById('download').click()");
      const file = join(dir, 'monohand-hands.jsonl');
      for (let i = 0; i < 60 && !existsSync(file); i++) await new Promise((ok) => setTimeout(ok, 500));
      if (!existsSync(file)) throw new Error('the download button gave no monohand-hands.jsonl');
      const lines = readFileSync(file, 'utf8').split('\n').filter(Boolean).map((l) => JSON.parse(l));
      rmSync(dir, { recursive: true, force: true });
      if (lines.length < demo.frames || lines.some((r, i) => r.frame !== i || !Array.isArray(r.hands))) {
        throw new Error(`the downloaded records are not the page's frames in order (${lines.length} lines, ${demo.frames} frames tracked before)`);
      }
      writeFileSync(args.download, lines.map((r) => JSON.stringify(r)).join('\n') + '\n');
      result.downloaded_frames = lines.length;
    }
    console.log(JSON.stringify(result));
    if (demo.hand3d || demo.hand3dFrames === 0) {
      console.error(`camera test: the demo page's 3D view showed no hand: ${demo.hand3d || 'no frame drawn'}`);
      process.exitCode = 1;
    }
    if (!(2 * demo.framesTicked > demo.frameMs.length)) {
      console.error(`camera test: the page's timer ticked during only ${demo.framesTicked} of ${demo.frameMs.length} tracker calls (its thread was blocked)`);
      process.exitCode = 1;
    }
    if ('every-frame' in args && demo.framesWithHand3d !== demo.frames) {
      console.error(`camera test: a hand in 3D in ${demo.framesWithHand3d} of ${demo.frames} camera frames, not in every one (--every-frame)`);
      process.exitCode = 1;
    }
    if (!(2 * demo.framesWithHand3d > demo.frames)) {
      console.error(`camera test: a hand in 3D in only ${demo.framesWithHand3d} of ${demo.frames} camera frames`);
      process.exitCode = 1;
    }
  }
} finally {
  await browser?.close();
  server.close();
}
