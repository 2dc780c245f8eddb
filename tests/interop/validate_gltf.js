// Validates GLB files with the Khronos glTF validator (npm gltf-validator, pinned in
// package.json) and exits non-zero when any file has an error or a warning.
// A .gltf file's external resources (scene.bin, textures/*.png) are read from its folder.
// Usage: node tests/interop/validate_gltf.js FILE.glb|FILE.gltf [...]
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

const SEVERITY = ['error', 'warning', 'info', 'hint'];

async function main(files) {
  if (files.length === 0) {
    console.error('usage: validate_gltf.js FILE.glb|FILE.gltf [...]');
    return 2;
  }
  let failed = 0;
  for (const file of files) {
    const bytes = new Uint8Array(fs.readFileSync(file));
    const dir = path.dirname(file);
    const report = await validator.validateBytes(bytes, {
      uri: file,
      maxIssues: 0,
      externalResourceFunction: (uri) =>
        new Promise((resolve, reject) => {
          fs.readFile(path.join(dir, decodeURIComponent(uri)), (err, data) =>
            err ? reject(err.toString()) : resolve(new Uint8Array(data)),
          );
        }),
    });
    const issues = report.issues;
    const info = report.info || {};
    console.log(
      `${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ` +
        `${issues.numInfos} infos, ${issues.numHints} hints; ` +
        `${info.drawCallCount} draw calls, ${info.totalVertexCount} vertices, ${info.totalTriangleCount} triangles`,
    );
    for (const m of issues.messages) {
      if (m.severity <= 1) {
        console.log(`  ${SEVERITY[m.severity]} ${m.code} at ${m.pointer || '-'}: ${m.message}`);
      }
    }
    if (issues.numErrors > 0 || issues.numWarnings > 0) {
      failed += 1;
    }
  }
  return failed === 0 ? 0 : 1;
}

main(process.argv.slice(2)).then(
  (code) => process.exit(code),
  (err) => {
    console.error(err);
    process.exit(1);
  },
);
