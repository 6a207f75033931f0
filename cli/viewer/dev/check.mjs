// Headless-Chromium smoke test of the sample pages (no dependencies beyond node).
//
//   node dev/make_sample.mjs --all && node dev/check.mjs
//   node dev/check.mjs [--times 0,0.9] OUTDIR/view.html ...   (any pages, e.g. from mbdc view)
//
// For dev/sample.html at two times it runs Chromium with --dump-dom (reads the
// <pre id="mbdc-test"> JSON) and with --screenshot (decodes the PNG with zlib),
// then checks: ready, no errors, the frame nearest the requested time, a pixel
// of each body's hue within 6 px of its screen position (the criterion of
// cli/tests/view.rs), and that the two screenshots differ in > 500 pixels. The edge-case pages must load with no errors.
// One time uses a plain `#t=` hash (the page pins its layout to the viewport at
// load in headless Chromium), the other pins it explicitly with `size=1000x700`.
// The flags are those of the Rust test (cli/tests/view.rs).

import { execFileSync } from 'node:child_process';
import { existsSync, readFileSync } from 'node:fs';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { inflateSync } from 'node:zlib';
import { tmpdir } from 'node:os';

const here = dirname(fileURLToPath(import.meta.url));
const CHROME = process.env.CHROMIUM || '/usr/bin/chromium';
const FLAGS = [
  '--headless', '--no-sandbox', '--disable-gpu-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
  '--hide-scrollbars', '--window-size=1000,800', '--virtual-time-budget=5000',
];
let failures = 0;
const fail = (msg) => { failures++; console.log(`FAIL ${msg}`); };
const ok = (msg) => console.log(`ok   ${msg}`);

function dumpState(url) {
  const dom = execFileSync(CHROME, [...FLAGS, '--dump-dom', url], { stdio: ['ignore', 'pipe', 'ignore'], maxBuffer: 1 << 28 }).toString();
  const m = /<pre id="mbdc-test"[^>]*>([^<]*)<\/pre>/.exec(dom);
  if (!m) return null;
  const ready = /<body[^>]*data-status="ready"/.test(dom);
  const state = JSON.parse(m[1].replace(/&quot;/g, '"').replace(/&lt;/g, '<').replace(/&gt;/g, '>').replace(/&amp;/g, '&'));
  return { state, ready };
}

function screenshot(url, path) {
  execFileSync(CHROME, [...FLAGS, `--screenshot=${path}`, url], { stdio: 'ignore' });
  return decodePng(readFileSync(path));
}

/** Minimal PNG decoder (8-bit RGB/RGBA, non-interlaced) -> {w, h, px(x, y)}. */
function decodePng(buf) {
  let o = 8;
  let w = 0;
  let h = 0;
  let ctype = 0;
  const idat = [];
  while (o < buf.length) {
    const len = buf.readUInt32BE(o);
    const type = buf.toString('ascii', o + 4, o + 8);
    const body = buf.subarray(o + 8, o + 8 + len);
    if (type === 'IHDR') {
      w = body.readUInt32BE(0); h = body.readUInt32BE(4); ctype = body[9];
      if (body[8] !== 8 || body[12] !== 0) throw new Error('unsupported PNG');
    } else if (type === 'IDAT') idat.push(body);
    o += 12 + len;
  }
  const bpp = ctype === 6 ? 4 : 3;
  const raw = inflateSync(Buffer.concat(idat));
  const stride = w * bpp;
  const out = Buffer.alloc(h * stride);
  for (let y = 0; y < h; y++) {
    const f = raw[y * (stride + 1)];
    const src = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let x = 0; x < stride; x++) {
      const a = x >= bpp ? out[y * stride + x - bpp] : 0;
      const b = y > 0 ? out[(y - 1) * stride + x] : 0;
      const c = x >= bpp && y > 0 ? out[(y - 1) * stride + x - bpp] : 0;
      let v = src[x];
      if (f === 1) v += a;
      else if (f === 2) v += b;
      else if (f === 3) v += (a + b) >> 1;
      else if (f === 4) {
        const p = a + b - c;
        const pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
        v += pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      }
      out[y * stride + x] = v & 255;
    }
  }
  return {
    w, h, data: out,
    px: (x, y) => [0, 1, 2].map((k) => out[(y * w + x) * bpp + k]),
  };
}

/** Hue in degrees, or null for greys (as in cli/tests/view.rs). */
function hue([r, g, b]) {
  [r, g, b] = [r / 255, g / 255, b / 255];
  const max = Math.max(r, g, b);
  const min = Math.min(r, g, b);
  if (max - min < 0.08) return null;
  const h = max === r ? (g - b) / (max - min) : max === g ? 2 + (b - r) / (max - min) : 4 + (r - g) / (max - min);
  return (((h * 60) % 360) + 360) % 360;
}

/** Chromaticity distance: compares colour direction, ignoring shading. */
function chromaDist(p, hex) {
  const c = [1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16));
  const n = (v) => { const s = v[0] + v[1] + v[2] + 1e-9; return v.map((x) => x / s); };
  const a = n(p);
  const b = n(c);
  return Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

/**
 * Check one page at each [t, extraHash] of `runs`: ready, no errors, frame near t,
 * bodies drawn where the page says they project; with two or more runs, the
 * first two screenshots must differ.
 */
function checkPage(page, runs) {
  const shots = [];
  const base = page.split('/').pop();
  runs.forEach(([t, extra], k) => {
    const url = `file://${page}#t=${t}${extra}`;
    const r = dumpState(url);
    if (!r) { fail(`${url}: no mbdc-test JSON`); return; }
    const { state, ready } = r;
    const tag = `${base} t=${t}`;
    if (ready && state.ready) ok(`${tag}: ready`); else fail(`${tag}: not ready`);
    if (state.errors.length === 0) ok(`${tag}: no errors`); else fail(`${tag}: errors ${JSON.stringify(state.errors)}`);
    ok(`${tag}: showing frame ${state.frame} at t=${state.t}`);
    const img = screenshot(url, join(tmpdir(), `mbdc-check-${k}.png`));
    shots.push(img);
    if (img.w === state.width) ok(`${tag}: screenshot width ${img.w}`); else fail(`${tag}: screenshot width ${img.w} != ${state.width}`);
    for (const b of state.bodies) {
      const [x, y] = b.px.map(Math.round);
      let best = Infinity;
      let bestPx = null;
      for (let dy = -2; dy <= 2; dy++) for (let dx = -2; dx <= 2; dx++) {
        const p = img.px(Math.min(img.w - 1, Math.max(0, x + dx)), Math.min(img.h - 1, Math.max(0, y + dy)));
        const d = chromaDist(p, b.color);
        if (d < best) { best = d; bestPx = p; }
      }
      // (informational: lighting and the highlight's glow shift the shade)
      console.log(`     ${tag}: body ${b.name} at (${x},${y}): nearest pixel rgb(${bestPx}) vs ${b.color} (chroma distance ${best.toFixed(3)})`);
      // The Rust test's criterion: a pixel of the body's hue (±20°) within 6 px.
      const want = hue([1, 3, 5].map((i) => parseInt(b.color.slice(i, i + 2), 16)));
      let near = false;
      for (let dy = -6; dy <= 6 && !near; dy++) for (let dx = -6; dx <= 6 && !near; dx++) {
        const h = hue(img.px(Math.min(img.w - 1, Math.max(0, x + dx)), Math.min(img.h - 1, Math.max(0, y + dy))));
        if (h != null && Math.min(Math.abs(h - want), 360 - Math.abs(h - want)) < 20) near = true;
      }
      if (near) ok(`${tag}: body ${b.name}: a pixel of its hue within 6 px`); else fail(`${tag}: body ${b.name}: no pixel of its hue within 6 px`);
    }
  });
  if (shots.length >= 2) {
    const [a, b] = shots;
    let diff = 0;
    for (let y = 0; y < Math.min(a.h, b.h); y++) {
      for (let x = 0; x < Math.min(a.w, b.w); x++) {
        const p = a.px(x, y);
        const q = b.px(x, y);
        if (p[0] !== q[0] || p[1] !== q[1] || p[2] !== q[2]) diff++;
      }
    }
    if (diff > 500) ok(`${base}: screenshots differ in ${diff} pixels`); else fail(`${base}: screenshots nearly identical (${diff} pixels differ)`);
  }
}

// Pages given on the command line: `node dev/check.mjs [--times 0,0.9] page.html ...`
const args = process.argv.slice(2);
const ti = args.indexOf('--times');
const times = ti >= 0 ? args.splice(ti, 2)[1].split(',').map(Number) : [0, 0.9];
if (args.length) {
  for (const page of args) checkPage(resolve(page), times.map((t) => [t, '']));
  console.log(failures ? `${failures} failure(s)` : 'all checks passed');
  process.exit(failures ? 1 : 0);
}

const sample = join(here, 'sample.html');
if (!existsSync(sample)) throw new Error('run node dev/make_sample.mjs --all first');
checkPage(sample, [[0.5, ''], [2.0, '&size=1000x700']]);
for (const name of ['sample-empty.html', 'sample-meshonly.html', 'sample-noframes.html']) {
  const path = join(here, name);
  if (!existsSync(path)) continue;
  for (const hash of ['', '#t=0.3']) {
    const r = dumpState(`file://${path}${hash}`);
    if (r && r.ready && r.state.errors.length === 0) ok(`${name}${hash}: ready, no errors`);
    else fail(`${name}${hash}: ${r ? JSON.stringify(r.state.errors) : 'no JSON'}`);
  }
}
console.log(failures ? `${failures} failure(s)` : 'all checks passed');
process.exit(failures ? 1 : 0);
