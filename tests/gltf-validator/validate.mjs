// Usage: node validate.mjs FILE.glb -> prints the validator's JSON report; exit 1 on errors.
import { readFileSync } from 'node:fs';
import validator from 'gltf-validator';

const file = process.argv[2];
const bytes = new Uint8Array(readFileSync(file));
const report = await validator.validateBytes(bytes, { uri: file, format: 'glb', maxIssues: 0, writeTimestamp: false });
console.log(JSON.stringify(report));
process.exit(report.issues.numErrors > 0 ? 1 : 0);
