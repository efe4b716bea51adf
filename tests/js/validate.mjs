// The Khronos glTF validator on one file: `node tests/js/validate.mjs FILE.glb` prints the
// validator's report as JSON on stdout and exits 0 when it has no errors (warnings, infos and
// hints allowed), 1 when it has errors, 2 when the file could not be read or the validator
// refused it (the reason on stderr). texgraph writes self-contained GLBs: a reference to an
// external file is refused (the report then has an IO_ERROR). tests/it/gltf_clients.rs runs it.
import { readFile } from 'node:fs/promises';
import { basename } from 'node:path';
import { validateBytes, version } from 'gltf-validator';

const file = process.argv[2];
if (!file || process.argv.length > 3) {
    console.error('usage: node validate.mjs FILE.glb');
    process.exit(2);
}
let bytes;
try {
    bytes = new Uint8Array(await readFile(file));
} catch (e) {
    console.error(`${file}: ${e.message}`);
    process.exit(2);
}
let report;
try {
    report = await validateBytes(bytes, {
        uri: basename(file),
        maxIssues: 0,
        writeTimestamp: false,
        externalResourceFunction: (uri) =>
            Promise.reject(`external resource ${uri} refused: a GLB is self-contained`),
    });
} catch (e) {
    console.error(`${file}: the validator refused it: ${e}`);
    process.exit(2);
}
report.validatorVersion ??= version();
console.log(JSON.stringify(report, null, 2));
// Not process.exit: that could cut a long report short on a pipe.
process.exitCode = report.issues.numErrors === 0 ? 0 : 1;
