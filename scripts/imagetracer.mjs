// imagetracerjs peer of the quality harness: node scripts/imagetracer.mjs IN.png OUT.svg
// Decodes the PNG to RGBA with pngjs (imagetracerjs wants RGBA ImageData) and traces it with the
// library's default options and 16 colours. Packages are looked up under $TRIXEL_NPM_PREFIX
// (default: <repo>/.cache/npm, where scripts/quality.sh installs them).
import { createRequire } from 'node:module';
import { readFileSync, writeFileSync } from 'node:fs';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const prefix = resolve(process.env.TRIXEL_NPM_PREFIX ?? join(here, '..', '.cache', 'npm'));
const require = createRequire(join(prefix, 'package.json'));

const [input, output] = process.argv.slice(2);
if (!input || !output) {
  console.error('usage: node scripts/imagetracer.mjs IN.png OUT.svg');
  process.exit(2);
}
let ImageTracer, PNG;
try {
  ImageTracer = require('imagetracerjs');
  ({ PNG } = require('pngjs'));
} catch (e) {
  console.error(`imagetracer.mjs: cannot load imagetracerjs/pngjs from ${prefix}: ${e.message}`);
  process.exit(1);
}
try {
  const png = PNG.sync.read(readFileSync(input)); // always RGBA, 8 bits per channel
  const image = { width: png.width, height: png.height, data: png.data };
  const svg = ImageTracer.imagedataToSVG(image, { numberofcolors: 16 });
  writeFileSync(output, svg);
} catch (e) {
  console.error(`imagetracer.mjs: ${input}: ${e.message}`);
  process.exit(1);
}
