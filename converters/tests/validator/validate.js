// Validates glTF/GLB files with the official Khronos validator (npm package gltf-validator).
// Usage: node validate.js FILE...  Prints one JSON line per file:
// {"file": ..., "errors": N, "warnings": N, "messages": [...errors...]} and exits 0.
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function main() {
  for (const file of process.argv.slice(2)) {
    const bytes = new Uint8Array(fs.readFileSync(file));
    const report = await validator.validateBytes(bytes, {
      uri: path.basename(file),
      maxIssues: 100,
      externalResourceFunction: (uri) =>
        new Promise((resolve, reject) => {
          fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (err, data) =>
            err ? reject(err.toString()) : resolve(new Uint8Array(data)));
        }),
    });
    const errors = report.issues.messages.filter((m) => m.severity === 0);
    console.log(JSON.stringify({ file, errors: report.issues.numErrors, warnings: report.issues.numWarnings, messages: errors }));
  }
}
main().catch((e) => { console.error(e); process.exit(2); });
