// Build the `mbdc view` browser bundle.
//
//   node build.mjs          bundle src/main.js -> ../assets/viewer.js (minified IIFE)
//   node build.mjs --check  only verify that ../assets/viewer.js was built from the
//                           current sources (exit status 1 if not)
//
// The bundle starts with a one-line comment carrying a sha256 of the sources:
// sha256 over, for each file of sorted(src/*.js) followed by ../assets/viewer.html
// (the page template), its path relative to cli/viewer, "\n", its bytes, "\n".

import { createHash } from 'node:crypto';
import { readdirSync, readFileSync, statSync, writeFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url)); // cli/viewer
const OUT = join(here, '..', 'assets', 'viewer.js');

/** Files covered by the source hash, as paths relative to cli/viewer. */
export function hashedFiles() {
  const src = readdirSync(join(here, 'src'))
    .filter((f) => f.endsWith('.js'))
    .sort()
    .map((f) => `src/${f}`);
  return [...src, '../assets/viewer.html'];
}

/** sha256 (hex) of the sources, as described above. */
export function sourceHash() {
  const h = createHash('sha256');
  for (const rel of hashedFiles()) {
    h.update(`${rel}\n`);
    h.update(readFileSync(join(here, rel)));
    h.update('\n');
  }
  return h.digest('hex');
}

function header(hash) {
  return `/* mbdc viewer bundle — three.js r187 (MIT, see THREE_LICENSE); built from cli/viewer/src by cli/viewer/build.mjs; source sha256 ${hash} */`;
}

async function build() {
  const { build: esbuild } = await import('esbuild');
  const hash = sourceHash();
  const result = await esbuild({
    absWorkingDir: here,
    entryPoints: ['src/main.js'],
    bundle: true,
    minify: true,
    format: 'iife',
    target: ['es2020'],
    platform: 'browser',
    charset: 'utf8',
    legalComments: 'eof', // keeps three's short @license line; full text in THREE_LICENSE
    banner: { js: header(hash) },
    write: false,
    metafile: true,
    logLevel: 'warning',
  });
  let js = result.outputFiles[0].text;
  // The bundle is pasted inside <script>...</script> by the Rust side: it must not
  // close the element early nor contain template placeholders.
  js = js.replace(/<\/(script)/gi, '<\\/$1');
  for (const p of ['TITLE', 'DATA', 'FRAMES', 'VIEWER']) {
    if (js.includes(`{{${p}}}`)) throw new Error(`bundle contains the placeholder {{${p}}}`);
  }
  if (!js.endsWith('\n')) js += '\n';
  writeFileSync(OUT, js);
  const kb = (n) => `${(n / 1024).toFixed(1)} KiB`;
  const inputs = Object.entries(result.metafile.outputs)[0][1].inputs;
  let three = 0;
  let own = 0;
  for (const [path, info] of Object.entries(inputs)) {
    if (path.includes('node_modules/three')) three += info.bytesInOutput; else own += info.bytesInOutput;
  }
  console.log(`wrote ${OUT}: ${kb(statSync(OUT).size)} (three.js ${kb(three)}, viewer ${kb(own)}); source sha256 ${hash}`);
}

function check() {
  const first = readFileSync(OUT, 'utf8').split('\n', 1)[0];
  const hash = sourceHash();
  if (first !== header(hash)) {
    console.error(`${OUT} is stale: rebuild with "cd cli/viewer && npm ci && node build.mjs"`);
    process.exit(1);
  }
  console.log(`${OUT} matches the sources (sha256 ${hash})`);
}

if (process.argv.includes('--check')) check();
else await build();
