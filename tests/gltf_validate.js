// Validates glTF / GLB files with the Khronos glTF Validator (npm
// gltf-validator, installed into the build tree by scripts/test-tools) and
// prints each report's counts and its issues; exits 1 when any file has an
// error or a warning (issue #16: 0 errors and 0 warnings).
// Usage: node gltf_validate.js NODE_MODULES FILE...
const fs = require('fs');
const path = require('path');
const validator = require(path.resolve(process.argv[2], 'gltf-validator'));

async function main() {
  let bad = 0;
  for (const file of process.argv.slice(3)) {
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
      uri: path.basename(file),
      maxIssues: 100,
    });
    const i = report.issues;
    console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, ` +
                `${i.numHints} hints`);
    for (const m of i.messages) {
      const severity = ['error', 'warning', 'info', 'hint'][m.severity];
      console.log(`  ${severity} ${m.code} ${m.pointer || ''}: ${m.message}`);
    }
    if (i.numErrors > 0 || i.numWarnings > 0) bad++;
  }
  process.exit(bad > 0 ? 1 : 0);
}
main().catch((e) => { console.error(e); process.exit(2); });
