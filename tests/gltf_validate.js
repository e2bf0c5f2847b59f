// Validate GLB files with the Khronos glTF validator (npm package gltf-validator).
// Usage: node gltf_validate.js VALIDATOR_DIR FILE...; prints one JSON object: file -> issues.
"use strict";
const fs = require("fs");
const validator = require(process.argv[2]);

(async () => {
  const out = {};
  for (const file of process.argv.slice(3)) {
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)),
                                                 {maxIssues: 0});
    out[file] = report.issues;
  }
  process.stdout.write(JSON.stringify(out));
})().catch((err) => { process.stderr.write(String(err) + "\n"); process.exit(1); });
