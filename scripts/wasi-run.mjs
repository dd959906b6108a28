// Runs a wasm32-wasip1 program (a test binary of cargo's) under Node's WASI, with the host's
// files under / and its environment: the runner of `cargo test --target wasm32-wasip1`
// (CARGO_TARGET_WASM32_WASIP1_RUNNER="node scripts/wasi-run.mjs"), so that the WebAssembly
// SIMD kernels are unit-tested as the native ones are (scripts/web-test.sh).
//
//   node scripts/wasi-run.mjs PROGRAM.wasm [ARGS...]

import { readFile } from 'node:fs/promises';
import { argv, env, exit } from 'node:process';
import { WASI } from 'node:wasi';

const [program, ...args] = argv.slice(2);
if (!program) {
  console.error('usage: node scripts/wasi-run.mjs PROGRAM.wasm [ARGS...]');
  exit(2);
}
const wasi = new WASI({
  version: 'preview1',
  args: [program, ...args],
  env,
  preopens: { '/': '/' },
  returnOnExit: true,
});
const module = await WebAssembly.compile(await readFile(program));
const instance = await WebAssembly.instantiate(module, wasi.getImportObject());
exit(wasi.start(instance));
