// Runs the Khronos glTF validator on every .glb/.gltf file named on the command line; prints
// one line per file with its error and warning counts and the codes seen, then a summary, and
// exits 1 when any file has an error. Used by scripts/validate-gltf.
const fs = require('fs');
const path = require('path');
const validator = require(process.env.GLTF_VALIDATOR);

async function validate(file) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        fs.readFile(path.join(path.dirname(file), decodeURIComponent(uri)), (err, data) =>
          err ? reject(err.toString()) : resolve(new Uint8Array(data)));
      }),
  });
  return report;
}

(async () => {
  let errors = 0;
  let warnings = 0;
  let meshes = 0;
  const files = process.argv.slice(2);
  for (const file of files) {
    const report = await validate(file);
    const codes = [...new Set(report.issues.messages.map((m) => m.code))];
    errors += report.issues.numErrors;
    warnings += report.issues.numWarnings;
    meshes += (report.info && report.info.drawCallCount) || 0;
    console.log(`${path.basename(file)}: ${report.issues.numErrors} errors, ` +
      `${report.issues.numWarnings} warnings${codes.length ? ' (' + codes.join(', ') + ')' : ''}`);
  }
  console.log(`glTF validator: ${files.length} files, ${meshes} meshes (draw calls), ${errors} errors, ` +
    `${warnings} warnings`);
  process.exit(errors > 0 ? 1 : 0);
})().catch((e) => {
  console.error(`glTF validator failed: ${e}`);
  process.exit(1);
});
