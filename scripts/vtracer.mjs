// VTracer peer of the quality harness: node scripts/vtracer.mjs IN.png OUT.svg
// Calls @neplex/vectorizer (VTracer) with its Poster preset. The package is looked up under
// $TRIXEL_NPM_PREFIX (default: <repo>/.cache/npm, where scripts/quality.sh installs it).
import { createRequire } from 'node:module';
import { readFileSync, writeFileSync } from 'node:fs';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const prefix = resolve(process.env.TRIXEL_NPM_PREFIX ?? join(here, '..', '.cache', 'npm'));
const require = createRequire(join(prefix, 'package.json'));

const [input, output] = process.argv.slice(2);
if (!input || !output) {
  console.error('usage: node scripts/vtracer.mjs IN.png OUT.svg');
  process.exit(2);
}
let vectorizer;
try {
  vectorizer = require('@neplex/vectorizer');
} catch (e) {
  console.error(`vtracer.mjs: cannot load @neplex/vectorizer from ${prefix}: ${e.message}`);
  process.exit(1);
}
try {
  const svg = vectorizer.vectorizeSync(readFileSync(input), vectorizer.Preset.Poster);
  writeFileSync(output, svg);
} catch (e) {
  console.error(`vtracer.mjs: ${input}: ${e.message}`);
  process.exit(1);
}
