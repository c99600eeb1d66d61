// Validate .glb files with Khronos' glTF validator (npm's gltf-validator, installed by `make test` under .tools/node);
// prints one JSON report per file: {"file", "numErrors", "numWarnings", "messages"}.
const fs = require('fs');
const path = require('path');
const validator = require(path.join(__dirname, '..', '.tools', 'node', 'node_modules', 'gltf-validator'));

(async () => {
  for (const file of process.argv.slice(2)) {
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {maxIssues: 100});
    const issues = report.issues;
    console.log(JSON.stringify({file, numErrors: issues.numErrors, numWarnings: issues.numWarnings,
                                messages: issues.messages.map((m) => `${m.code}: ${m.message} (${m.pointer || ''})`)}));
  }
})().catch((e) => { console.error(String(e)); process.exit(2); });
