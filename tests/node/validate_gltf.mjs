// Validates GLB files with the Khronos glTF validator (npm gltf-validator).
// Usage: node tests/node/validate_gltf.mjs FILE.glb...
// Prints one JSON line per file ({file, errors, warnings, infos, hints, messages}) and exits 1 when any file has
// an error or a warning, 2 on a usage or read failure.
import { readFile } from 'node:fs/promises';
import validator from 'gltf-validator';

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: validate_gltf.mjs FILE.glb...');
  process.exit(2);
}
let failed = false;
for (const file of files) {
  const bytes = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(bytes, {
    uri: file,
    maxIssues: 100,
    // Nothing external: a GLB of ours carries everything in its binary chunk.
    externalResourceFunction: (uri) => Promise.reject(new Error(`unexpected external resource ${uri}`)),
  });
  const issues = report.issues;
  const summary = {
    file,
    errors: issues.numErrors,
    warnings: issues.numWarnings,
    infos: issues.numInfos,
    hints: issues.numHints,
    messages: issues.messages.map((m) => `${m.severity === 0 ? 'error' : m.severity === 1 ? 'warning' : m.severity === 2 ? 'info' : 'hint'} ${m.code} ${m.pointer ?? ''}: ${m.message}`),
  };
  console.log(JSON.stringify(summary));
  if (issues.numErrors > 0 || issues.numWarnings > 0) failed = true;
}
process.exitCode = failed ? 1 : 0;  // not process.exit(): it would cut stdout short on a pipe
