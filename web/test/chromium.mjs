// What the browser tests' drivers share: a static file server on 127.0.0.1 only (an
// ephemeral port), headless Chromium with its DevTools protocol on 127.0.0.1 too, and a
// page driven over that protocol with Node's own WebSocket (`node --experimental-websocket`;
// Node 20.10 or newer). No npm package is used.

import { spawn } from 'node:child_process';
import { createReadStream, mkdtempSync, rmSync, statSync } from 'node:fs';
import { createServer } from 'node:http';
import { tmpdir } from 'node:os';
import { extname, join, normalize, resolve, sep } from 'node:path';

/** The command line's `--name value` and `--name=value` pairs as an object. */
export function parseArgs(argv = process.argv.slice(2)) {
  const args = {};
  for (let i = 0; i < argv.length; i++) {
    if (!argv[i].startsWith('--')) continue;
    const eq = argv[i].indexOf('=');
    if (eq > 0) args[argv[i].slice(2, eq)] = argv[i].slice(eq + 1);
    else args[argv[i].slice(2)] = argv[i + 1];
  }
  return args;
}

const TYPES = {
  '.html': 'text/html', '.js': 'text/javascript', '.mjs': 'text/javascript',
  '.wasm': 'application/wasm', '.json': 'application/json', '.png': 'image/png',
  '.css': 'text/css', '.tflite': 'application/octet-stream', '.binarypb': 'application/octet-stream',
  '.data': 'application/octet-stream',
};

/**
 * Serves the folders of `mounts` (`{'/': dir, '/extra/': dir, ...}`; the longest prefix
 * wins) and the single files of `files` (`{'/clip.rgba': file}`) on 127.0.0.1. Resolves to
 * `{ port, close() }`. `onRequest(path)` is called with each path asked for. `isolated`
 * (default true) sends the headers that make a page cross-origin isolated (COOP/COEP, as
 * scripts/web-serve.sh does), which WebAssembly threads need; false leaves them out.
 */
export async function serve({ mounts, files = {}, onRequest = () => {}, isolated = true }) {
  const roots = Object.entries(mounts).map(([prefix, dir]) => [prefix, resolve(dir)])
    .sort((a, b) => b[0].length - a[0].length);
  const server = createServer((req, res) => {
    const path = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    onRequest(path);
    let file = files[path] ? resolve(files[path]) : null;
    if (!file) {
      const [prefix, root] = roots.find(([p]) => path.startsWith(p)) ?? [];
      if (!root) { res.writeHead(404).end('not found'); return; }
      file = normalize(join(root, path.slice(prefix.length)));
      if (!file.startsWith(root + sep)) { res.writeHead(403).end(); return; }
    }
    let st;
    try {
      st = statSync(file);
    } catch {
      res.writeHead(404).end('not found');
      return;
    }
    if (!st.isFile()) { res.writeHead(404).end('not found'); return; }
    res.writeHead(200, {
      'Content-Type': TYPES[extname(file)] ?? 'application/octet-stream',
      'Content-Length': st.size,
      ...(isolated ? {
        'Cross-Origin-Opener-Policy': 'same-origin',
        'Cross-Origin-Embedder-Policy': 'require-corp',
      } : {}),
    });
    createReadStream(file).pipe(res);
  });
  await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
  return { port: server.address().port, close: () => server.close() };
}

/**
 * Starts headless Chromium (`flags` added to the usual ones; `webgl: true` leaves out
 * `--disable-gpu`, for pages that need WebGL from the software renderer) and opens a DevTools session
 * on its page. Resolves to `{ send(method, params), evaluate(expression), waitFor(expression,
 * timeoutS), screenshot(), close() }` (close resolves once Chromium has exited and its profile is removed); the page's console and exceptions go to stderr.
 */
export async function launch({ chromium = '/usr/bin/chromium', flags = [], webgl = false } = {}) {
  const profile = mkdtempSync(join(tmpdir(), 'monohand-web-chromium-'));
  const child = spawn(chromium, [
    '--headless=new', '--no-sandbox', ...(webgl ? [] : ['--disable-gpu']), '--no-first-run',
    '--disable-extensions', '--disable-background-networking', '--disable-sync',
    '--remote-debugging-address=127.0.0.1', '--remote-debugging-port=0',
    `--user-data-dir=${profile}`, '--window-size=1040,780', ...flags, 'about:blank',
  ], { stdio: ['ignore', 'ignore', 'pipe'], detached: true, env: { ...process.env, TMPDIR: profile } });
  let ws = null;
  // Chromium in a process group of its own (detached), so that its renderer, GPU and
  // utility processes end with it: killing the browser alone left them running for a
  // moment, writing into the profile folder after it was removed (one left in /tmp a run).
  // The group is ended on close, on this script's exit, and on Ctrl-C; the folder is
  // removed once the browser is gone. Its temporary files (the singleton socket Chromium
  // leaves in $TMPDIR even when it exits cleanly) go into the profile folder too.
  const killGroup = (signal) => {
    try { process.kill(-child.pid, signal); } catch { /* already gone */ }
  };
  const onSignal = () => { killGroup('SIGKILL'); process.exit(130); };
  const onExit = () => killGroup('SIGKILL');
  process.once('SIGINT', onSignal);
  process.once('SIGTERM', onSignal);
  process.once('exit', onExit);
  const gone = new Promise((ok) => {
    if (child.exitCode !== null || child.signalCode !== null) ok();
    else child.once('exit', ok);
  });
  const close = async () => {
    try { ws?.close(); } catch { /* already closed */ }
    // SIGTERM first: Chromium then removes its own files in /tmp; SIGKILL after 3 s.
    killGroup('SIGTERM');
    const late = setTimeout(() => killGroup('SIGKILL'), 3000);
    await gone;
    clearTimeout(late);
    killGroup('SIGKILL');
    process.off('SIGINT', onSignal);
    process.off('SIGTERM', onSignal);
    process.off('exit', onExit);
    for (let i = 0; i < 10; i++) {
      try {
        rmSync(profile, { recursive: true, force: true });
        return;
      } catch { await new Promise((ok) => setTimeout(ok, 100)); }
    }
  };
  try {
    const browserWs = await new Promise((ok, fail) => {
      let text = '';
      const timer = setTimeout(() => fail(new Error(`Chromium did not start:\n${text}`)), 30000);
      child.stderr.on('data', (d) => {
        text += d;
        const m = text.match(/DevTools listening on (ws:\/\/\S+)/);
        if (m) { clearTimeout(timer); ok(m[1]); }
      });
      child.on('exit', (code) => fail(new Error(`Chromium exited (${code}):\n${text}`)));
    });
    const devtools = new URL(browserWs).host;
    const targets = await (await fetch(`http://${devtools}/json/list`)).json();
    const target = targets.find((t) => t.type === 'page');
    ws = new WebSocket(target.webSocketDebuggerUrl);
    await new Promise((ok, fail) => { ws.onopen = ok; ws.onerror = () => fail(new Error('DevTools socket failed')); });
  } catch (e) {
    await close();
    throw e;
  }
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
  const evaluate = async (expression) => {
    const r = await send('Runtime.evaluate', { expression, returnByValue: true });
    return r.result.value;
  };
  /** Polls `expression` (JSON text or null) every half second until it gives a value. */
  const waitFor = async (expression, timeoutS, what) => {
    const deadline = Date.now() + timeoutS * 1000;
    for (;;) {
      const v = await evaluate(expression);
      if (v !== null && v !== undefined) return JSON.parse(v);
      if (Date.now() > deadline) throw new Error(`${what ?? 'the page'} gave no result in ${timeoutS} s`);
      await new Promise((ok) => setTimeout(ok, 500));
    }
  };
  const screenshot = async () => Buffer.from((await send('Page.captureScreenshot', { format: 'png' })).data, 'base64');
  return { send, evaluate, waitFor, screenshot, close };
}
