// The Khronos glTF validator (npm gltf-validator, pinned in package-lock.json beside this
// file) on a `.glb` that `monohand run --gltf` wrote (issue 43). Requires no error, no
// warning and no information message (hints are listed, not counted), and, with
// `--skinned`, that the file is the skinned hand: a skin, a skinned mesh node at the scene's
// root, and an animation of at least `--min-keys` keys. Prints one JSON line:
//   {"file": ..., "errors": 0, "warnings": 0, "infos": 0, "hints": 0, "keys": N, ...}
// and exits 1 with the messages on stderr when the file falls short.
//
//   node web/test/gltf-validate/validate.mjs FILE.glb [--skinned] [--min-keys N]
import { readFileSync } from 'node:fs';
import { basename } from 'node:path';
import validator from 'gltf-validator';

const args = process.argv.slice(2);
const file = args.find((a) => !a.startsWith('--'));
const skinned = args.includes('--skinned');
const minKeysAt = args.indexOf('--min-keys');
const minKeys = minKeysAt >= 0 ? Number(args[minKeysAt + 1]) : 0;
if (!file || !Number.isFinite(minKeys)) {
  console.error('usage: validate.mjs FILE.glb [--skinned] [--min-keys N]');
  process.exit(2);
}

const bytes = new Uint8Array(readFileSync(file));
const report = await validator.validateBytes(bytes, {
  uri: basename(file),
  maxIssues: 0, // all of them
  format: 'glb',
});
const { numErrors, numWarnings, numInfos, numHints, messages } = report.issues;

// What a viewer is given: read from the file's own JSON chunk.
const jsonLength = new DataView(bytes.buffer, bytes.byteOffset).getUint32(12, true);
const gltf = JSON.parse(new TextDecoder().decode(bytes.subarray(20, 20 + jsonLength)));
const roots = new Set(gltf.scenes?.[gltf.scene ?? 0]?.nodes ?? []);
const skinnedNodes = (gltf.nodes ?? []).flatMap((n, i) => (n.skin !== undefined ? [i] : []));
const keys = Math.max(0, ...(gltf.animations ?? []).flatMap((a) =>
  a.samplers.map((s) => gltf.accessors[s.input].count)));

const problems = [];
if (numErrors + numWarnings + numInfos > 0) {
  const counts = new Map();
  for (const m of messages.filter((m) => m.severity <= 2)) {
    const c = counts.get(m.code) ?? { n: 0, first: m };
    c.n += 1;
    counts.set(m.code, c);
  }
  for (const [code, { n, first }] of counts) {
    problems.push(`${n} x ${code} (severity ${first.severity}), first at ${first.pointer ?? '-'}: ${first.message}`);
  }
}
if (skinned) {
  if (!gltf.skins?.length) problems.push('no skin: not the skinned hand');
  if (!skinnedNodes.length) problems.push('no node with a skinned mesh');
  for (const i of skinnedNodes) {
    if (!roots.has(i)) problems.push(`skinned mesh node ${i} (${gltf.nodes[i].name}) is not a root of the scene`);
  }
}
if (keys < minKeys) problems.push(`${keys} animation keys, fewer than ${minKeys}`);

console.log(JSON.stringify({
  file: basename(file),
  validator: report.validatorVersion,
  errors: numErrors,
  warnings: numWarnings,
  infos: numInfos,
  hints: numHints,
  hint_codes: [...new Set(messages.filter((m) => m.severity === 3).map((m) => m.code))],
  skins: gltf.skins?.length ?? 0,
  skinned_mesh_nodes: skinnedNodes.length,
  keys,
}));
if (problems.length) {
  for (const p of problems) console.error(`gltf-validate: ${file}: ${p}`);
  process.exit(1);
}
