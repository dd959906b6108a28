// Drives the browser test: serves web/ and the clip on 127.0.0.1 only, opens the test page
// in headless Chromium, reads the page's result over the DevTools protocol (Node's own
// WebSocket: run with `node --experimental-websocket`), writes the records as JSON Lines
// and a screenshot, and prints the timings as JSON on its last line.
//
//   node --experimental-websocket run.mjs --web DIR --clip FILE.rgba --size WxH --fps N \
//        --out records.jsonl --screenshot shot.png [--chromium PATH] [--timeout SECS]
//        [--extra DIR (served as /extra/)] [--query '&weights=/extra/' (added to the page's URL)]
//        [--expect-error TEXT: the page must fail with a message containing TEXT]

import { spawn } from 'node:child_process';
import { createReadStream, mkdtempSync, rmSync, statSync, writeFileSync } from 'node:fs';
import { createServer } from 'node:http';
import { tmpdir } from 'node:os';
import { extname, join, normalize, resolve, sep } from 'node:path';

const args = Object.fromEntries(
  process.argv.slice(2).reduce((pairs, a, i, all) => (a.startsWith('--') ? [...pairs, [a.slice(2), all[i + 1]]] : pairs), []),
);
for (const need of ['web', 'clip', 'size', 'out']) {
  if (!args[need]) throw new Error(`--${need} is required`);
}
const [w, h] = args.size.split('x').map(Number);
const timeoutS = Number(args.timeout ?? 900);

const TYPES = {
  '.html': 'text/html', '.js': 'text/javascript', '.mjs': 'text/javascript',
  '.wasm': 'application/wasm', '.json': 'application/json',
};

// Static files: /clip.rgba is the clip, everything else under --web.
const webRoot = resolve(args.web);
const server = createServer((req, res) => {
  const path = decodeURIComponent(new URL(req.url, 'http://x').pathname);
  const extra = args.extra && path.startsWith('/extra/');
  const root = extra ? resolve(args.extra) : webRoot;
  const file = path === '/clip.rgba' ? resolve(args.clip)
    : normalize(join(root, extra ? path.slice('/extra/'.length) : path));
  if (path !== '/clip.rgba' && !file.startsWith(root + sep)) {
    res.writeHead(403).end();
    return;
  }
  let st;
  try {
    st = statSync(file);
  } catch {
    res.writeHead(404).end('not found');
    return;
  }
  if (!st.isFile()) {
    res.writeHead(404).end('not found');
    return;
  }
  res.writeHead(200, {
    'Content-Type': TYPES[extname(file)] ?? 'application/octet-stream',
    'Content-Length': st.size,
  });
  createReadStream(file).pipe(res);
});
await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
const port = server.address().port;

const profile = mkdtempSync(join(tmpdir(), 'monohand-web-chromium-'));
const chromium = spawn(args.chromium ?? '/usr/bin/chromium', [
  '--headless=new', '--no-sandbox', '--disable-gpu', '--no-first-run',
  '--disable-extensions', '--disable-background-networking', '--disable-sync',
  '--remote-debugging-address=127.0.0.1', '--remote-debugging-port=0',
  `--user-data-dir=${profile}`, '--window-size=700,600', 'about:blank',
], { stdio: ['ignore', 'ignore', 'pipe'] });

function cleanup() {
  chromium.kill('SIGKILL');
  server.close();
  try { rmSync(profile, { recursive: true, force: true }); } catch { /* left in /tmp */ }
}

try {
  const browserWs = await new Promise((ok, fail) => {
    let text = '';
    const timer = setTimeout(() => fail(new Error(`Chromium did not start:\n${text}`)), 30000);
    chromium.stderr.on('data', (d) => {
      text += d;
      const m = text.match(/DevTools listening on (ws:\/\/\S+)/);
      if (m) { clearTimeout(timer); ok(m[1]); }
    });
    chromium.on('exit', (code) => fail(new Error(`Chromium exited (${code}):\n${text}`)));
  });
  const devtools = new URL(browserWs).host;
  const targets = await (await fetch(`http://${devtools}/json/list`)).json();
  const page = targets.find((t) => t.type === 'page');
  const ws = new WebSocket(page.webSocketDebuggerUrl);
  await new Promise((ok, fail) => { ws.onopen = ok; ws.onerror = () => fail(new Error('DevTools socket failed')); });
  let nextId = 1;
  const pending = new Map();
  ws.onmessage = (event) => {
    const msg = JSON.parse(event.data);
    if (msg.id && pending.has(msg.id)) {
      const { ok, fail } = pending.get(msg.id);
      pending.delete(msg.id);
      if (msg.error) fail(new Error(JSON.stringify(msg.error))); else ok(msg.result);
    } else if (msg.method === 'Runtime.consoleAPICalled') {
      console.error(`[page ${msg.params.type}]`, msg.params.args.map((a) => a.value ?? a.description).join(' '));
    } else if (msg.method === 'Runtime.exceptionThrown') {
      console.error('[page exception]', msg.params.exceptionDetails.exception?.description ?? msg.params.exceptionDetails.text);
    }
  };
  const send = (method, params = {}) => new Promise((ok, fail) => {
    const id = nextId++;
    pending.set(id, { ok, fail });
    ws.send(JSON.stringify({ id, method, params }));
  });
  await send('Runtime.enable');
  await send('Page.enable');
  const url = `http://127.0.0.1:${port}/test/index.html?clip=/clip.rgba&w=${w}&h=${h}&fps=${args.fps ?? 30}${args.query ?? ''}`;
  await send('Page.navigate', { url });
  const deadline = Date.now() + timeoutS * 1000;
  let result = null;
  while (!result) {
    if (Date.now() > deadline) throw new Error(`the page gave no result in ${timeoutS} s`);
    await new Promise((ok) => setTimeout(ok, 500));
    const r = await send('Runtime.evaluate', {
      expression: 'window.monohandResult ? JSON.stringify(window.monohandResult) : null',
      returnByValue: true,
    });
    if (r.result.value) result = JSON.parse(r.result.value);
  }
  if (args['expect-error'] !== undefined) {
    // The page must have said what went wrong, in these words.
    if (!result.error?.includes(args['expect-error'])) {
      throw new Error(`expected the page to fail with "${args['expect-error']}", got ${JSON.stringify(result.error ?? 'no error')}`);
    }
    console.log(JSON.stringify({ error: result.error }));
    ws.close();
    process.exitCode = 0;
  } else {
  if (result.error) throw new Error(`the page failed: ${result.error}`);
  writeFileSync(args.out, result.records.map((r) => JSON.stringify(r)).join('\n') + '\n');
  if (args.screenshot) {
    const shot = await send('Page.captureScreenshot', { format: 'png' });
    writeFileSync(args.screenshot, Buffer.from(shot.data, 'base64'));
  }
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
    user_agent: result.userAgent,
  }));
  ws.close();
  }
} finally {
  cleanup();
}
