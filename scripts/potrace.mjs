// potrace peer of the quality harness: node scripts/potrace.mjs IN.png OUT.svg [COLOURS]
//
// potrace traces bitmaps only, so colour input is traced in layers, kept deliberately simple:
//  1. quantize the opaque pixels (alpha >= 128) to COLOURS colours (default 16): median cut, then
//     three rounds of k-means (nearest colour in RGB, centres moved to their pixels' mean);
//  2. sort the colours by pixel count, largest first;
//  3. layer i is the bitmap of every pixel whose colour is i or later in that order, traced by
//     `potrace -b svg` and filled with colour i;
//  4. the layers are stacked in order in one SVG. Each layer covers the ones after it, so potrace's
//     smoothing of each layer's outline leaves no gaps between colours; the last layer painted over
//     a pixel is its own colour. Transparent pixels are in no layer.
// Packages are looked up under $TRIXEL_NPM_PREFIX (default: <repo>/.cache/npm); potrace from PATH.
import { createRequire } from 'node:module';
import { readFileSync, writeFileSync } from 'node:fs';
import { spawnSync } from 'node:child_process';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const prefix = resolve(process.env.TRIXEL_NPM_PREFIX ?? join(here, '..', '.cache', 'npm'));
const require = createRequire(join(prefix, 'package.json'));

const [input, output, coloursArg] = process.argv.slice(2);
const numColours = coloursArg === undefined ? 16 : Number(coloursArg);
if (!input || !output || !Number.isInteger(numColours) || numColours < 1 || numColours > 256) {
  console.error('usage: node scripts/potrace.mjs IN.png OUT.svg [COLOURS 1..256]');
  process.exit(2);
}
let PNG;
try {
  ({ PNG } = require('pngjs'));
} catch (e) {
  console.error(`potrace.mjs: cannot load pngjs from ${prefix}: ${e.message}`);
  process.exit(1);
}

function fail(message) {
  console.error(`potrace.mjs: ${input}: ${message}`);
  process.exit(1);
}

// Median cut: split the box with the widest channel range at its median until there are enough.
function medianCut(pixels, count) {
  let boxes = [pixels];
  while (boxes.length < count) {
    let best = -1, bestRange = 0, bestChannel = 0;
    boxes.forEach((box, i) => {
      if (box.length < 2) return;
      for (let c = 0; c < 3; ++c) {
        let lo = 255, hi = 0;
        for (const p of box) { lo = Math.min(lo, p[c]); hi = Math.max(hi, p[c]); }
        if (hi - lo > bestRange) { bestRange = hi - lo; best = i; bestChannel = c; }
      }
    });
    if (best < 0) break; // every box holds one colour
    const box = boxes[best].sort((a, b) => a[bestChannel] - b[bestChannel]);
    const mid = box.length >> 1;
    boxes.splice(best, 1, box.slice(0, mid), box.slice(mid));
  }
  return boxes.map((box) => {
    const s = [0, 0, 0];
    for (const p of box) for (let c = 0; c < 3; ++c) s[c] += p[c];
    return s.map((v) => v / box.length);
  });
}

function nearest(centres, r, g, b) {
  let best = 0, bestD = Infinity;
  for (let k = 0; k < centres.length; ++k) {
    const c = centres[k];
    const d = (c[0] - r) ** 2 + (c[1] - g) ** 2 + (c[2] - b) ** 2;
    if (d < bestD) { bestD = d; best = k; }
  }
  return best;
}

let png;
try {
  png = PNG.sync.read(readFileSync(input)); // RGBA, 8 bits per channel
} catch (e) {
  fail(e.message);
}
const { width, height, data } = png;
const n = width * height;
const opaque = new Uint8Array(n);
const samples = [];
// Median cut on a regular sample of at most ~50k pixels keeps it fast on photographs.
const stride = Math.max(1, Math.floor(n / 50000));
for (let i = 0; i < n; ++i) {
  opaque[i] = data[4 * i + 3] >= 128 ? 1 : 0;
  if (opaque[i] && i % stride === 0) samples.push([data[4 * i], data[4 * i + 1], data[4 * i + 2]]);
}
if (samples.length === 0) fail('no opaque pixels');

let centres = medianCut(samples, numColours);
const label = new Int32Array(n).fill(-1);
for (let round = 0; round < 4; ++round) {
  const sum = centres.map(() => [0, 0, 0, 0]);
  for (let i = 0; i < n; ++i) {
    if (!opaque[i]) continue;
    const k = nearest(centres, data[4 * i], data[4 * i + 1], data[4 * i + 2]);
    label[i] = k;
    const s = sum[k];
    s[0] += data[4 * i]; s[1] += data[4 * i + 1]; s[2] += data[4 * i + 2]; s[3] += 1;
  }
  if (round === 3) break; // the last round only assigns
  centres = centres.map((c, k) => (sum[k][3] > 0 ? sum[k].slice(0, 3).map((v) => v / sum[k][3]) : c));
}

const counts = centres.map(() => 0);
for (let i = 0; i < n; ++i) if (label[i] >= 0) counts[label[i]] += 1;
const order = centres.map((_, k) => k).filter((k) => counts[k] > 0).sort((a, b) => counts[b] - counts[a]);
const rank = new Int32Array(centres.length);
order.forEach((k, r) => { rank[k] = r; });

const hex = (c) => '#' + c.map((v) => Math.round(v).toString(16).padStart(2, '0')).join('');
const rowBytes = (width + 7) >> 3;
const groups = [];
for (let layer = 0; layer < order.length; ++layer) {
  // PBM (P4): 1 = black = traced.
  const header = Buffer.from(`P4\n${width} ${height}\n`);
  const bits = Buffer.alloc(rowBytes * height);
  for (let y = 0; y < height; ++y) {
    for (let x = 0; x < width; ++x) {
      const i = y * width + x;
      if (label[i] >= 0 && rank[label[i]] >= layer) bits[y * rowBytes + (x >> 3)] |= 0x80 >> (x & 7);
    }
  }
  const traced = spawnSync('potrace', ['-b', 'svg', '-C', hex(centres[order[layer]]), '-o', '-'], {
    input: Buffer.concat([header, bits]),
    maxBuffer: 1 << 30,
  });
  if (traced.error) fail(`cannot run potrace: ${traced.error.message}`);
  if (traced.status !== 0) fail(`potrace failed: ${traced.stderr.toString().trim()}`);
  const svg = traced.stdout.toString();
  const start = svg.indexOf('<g ');
  const end = svg.lastIndexOf('</g>');
  if (start < 0 || end < 0) fail('unexpected potrace output (no <g> group)');
  groups.push(svg.slice(start, end + 4));
}

writeFileSync(
  output,
  `<svg xmlns="http://www.w3.org/2000/svg" width="${width}" height="${height}" viewBox="0 0 ${width} ${height}">\n` +
    groups.join('\n') +
    '\n</svg>\n',
);
