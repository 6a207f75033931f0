// Write sample pages from synthetic data, filling ../../assets/viewer.html the
// way the Rust side does (for developing and testing the viewer).
//
//   node dev/make_sample.mjs              -> dev/sample.html (the full sample)
//   node dev/make_sample.mjs --all        -> also the edge cases:
//        dev/sample-empty.html      zero bodies, no curves, a single frame
//        dev/sample-meshonly.html   a mesh (with bars) only, finished run
//        dev/sample-noframes.html   a model but zero frames
//
// The full sample: a 3-D double pendulum (two 1 m box links, a revolute to
// ground and one between the links), a spring, a ground plane, a beam of six
// nodes waving (with section forces: N1, |M|, M1 per element), a 2x1x1 two-hex mesh whose displacement and von Mises vary in
// time, and a "failed" status with a report and a highlighted joint.

import { readFileSync, writeFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const TEMPLATE = join(here, '..', '..', 'assets', 'viewer.html');
const BUNDLE = join(here, '..', '..', 'assets', 'viewer.js');

// ---------------------------------------------------------------------------
// Small quaternion helpers, (w, x, y, z).
const qmul = (a, b) => [
  a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
  a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
  a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
  a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
];
const qaxis = (ax, ang) => [Math.cos(ang / 2), ...ax.map((c) => c * Math.sin(ang / 2))];
function qrot(q, v) {
  const p = qmul(qmul(q, [0, ...v]), [q[0], -q[1], -q[2], -q[3]]);
  return [p[1], p[2], p[3]];
}

// ---------------------------------------------------------------------------
// Double pendulum (point masses m=1 at the link ends, l=1, g=9.81) in a vertical
// plane that slowly turns about z, integrated with RK4.
const G = 9.81;
function deriv([t1, t2, w1, w2]) {
  const d = t1 - t2;
  const den = 3 - Math.cos(2 * d);
  const a1 = (-G * 3 * Math.sin(t1) - G * Math.sin(t1 - 2 * t2) - 2 * Math.sin(d) * (w2 * w2 + w1 * w1 * Math.cos(d))) / den;
  const a2 = (2 * Math.sin(d) * (w1 * w1 * 2 + G * 2 * Math.cos(t1) + w2 * w2 * Math.cos(d))) / den;
  return [w1, w2, a1, a2];
}
function rk4(y, h) {
  const add = (a, b, s) => a.map((x, i) => x + s * b[i]);
  const k1 = deriv(y);
  const k2 = deriv(add(y, k1, h / 2));
  const k3 = deriv(add(y, k2, h / 2));
  const k4 = deriv(add(y, k3, h));
  return y.map((x, i) => x + (h / 6) * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]));
}
function energies([t1, t2, w1, w2]) {
  const kin = 0.5 * (2 * w1 * w1 + w2 * w2 + 2 * w1 * w2 * Math.cos(t1 - t2));
  const pot = -G * (2 * Math.cos(t1) + Math.cos(t2));
  return [kin, pot];
}

// ---------------------------------------------------------------------------
// The two-hex box mesh: nodes on a 3x2x2 grid over [0,2]x[0,1]x[0,1].
function boxMesh(origin) {
  const points = [];
  const id = (i, j, k) => i * 4 + j * 2 + k;
  for (let i = 0; i < 3; i++) for (let j = 0; j < 2; j++) for (let k = 0; k < 2; k++) {
    points.push(origin[0] + i, origin[1] + j, origin[2] + k);
  }
  const tris = [];
  const quad = (a, b, c, d) => tris.push(a, b, c, a, c, d);
  quad(id(0, 0, 0), id(0, 1, 0), id(0, 1, 1), id(0, 0, 1)); // x = 0
  quad(id(2, 0, 0), id(2, 0, 1), id(2, 1, 1), id(2, 1, 0)); // x = 2
  for (let i = 0; i < 2; i++) {
    quad(id(i, 0, 0), id(i, 0, 1), id(i + 1, 0, 1), id(i + 1, 0, 0)); // y = 0
    quad(id(i, 1, 0), id(i + 1, 1, 0), id(i + 1, 1, 1), id(i, 1, 1)); // y = 1
    quad(id(i, 0, 0), id(i + 1, 0, 0), id(i + 1, 1, 0), id(i, 1, 0)); // z = 0
    quad(id(i, 0, 1), id(i, 1, 1), id(i + 1, 1, 1), id(i + 1, 0, 1)); // z = 1
  }
  return { points, triangles: tris };
}

// ---------------------------------------------------------------------------
function fullSample() {
  const step = 0.001;
  const every = 10;
  const tFail = 3.0;
  const runFrames = Math.round(tFail / step) + 1;
  const F = Math.floor((runFrames - 1) / every) + 1;

  const bodies = [
    { name: 'rod1', shape: { kind: 'box', size: [1, 0.08, 0.08] }, color: '#4e79a7' },
    { name: 'rod2', shape: { kind: 'box', size: [1, 0.08, 0.08] }, color: '#f28e2b' },
  ];
  const beamSlots = [];
  for (let n = 0; n < 6; n++) {
    beamSlots.push(bodies.length);
    bodies.push({ name: `arm.n${n}`, shape: { kind: 'none' }, color: '#9c755f' });
  }
  const mesh = boxMesh([-4, -0.5, -2.3]);
  mesh.name = 'plate';
  mesh.lines = [];
  const nNodes = mesh.points.length / 3;

  const slots = bodies.length;
  const nElements = beamSlots.length - 1;
  const S = 1 + 7 * slots + 4 * nNodes + 3 * nElements;
  const beamMax = [0, 0, 0]; // largest |N1|, |M|, |M1|
  const frames = new Float32Array(F * S);
  const curveT = [];
  const kinetic = [];
  const potential = [];
  const total = [];
  const drift = [];
  const violation = [];

  let y = [2.0, 2.6, 0, 0];
  const e0 = energies(y).reduce((a, b) => a + b);
  let vmMax = 0;
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  const grow = (p) => p.forEach((c, i) => { lo[i] = Math.min(lo[i], c); hi[i] = Math.max(hi[i], c); });

  for (let n = 0, f = 0; n < runFrames; n++) {
    const t = n * step;
    if (n % 5 === 0) {
      const [k, p] = energies(y);
      curveT.push(t);
      kinetic.push(k);
      potential.push(p);
      total.push(k + p);
      drift.push((k + p - e0) / Math.abs(e0) + 2e-6 * t * t * t); // a little fake drift
      violation.push(1e-9 * Math.exp(4.5 * t)); // grows until the failure
    }
    if (n % every === 0) {
      const o = f * S;
      frames[o] = t;
      const psi = 0.35 * Math.sin(0.6 * t); // the swing plane turns about z
      const qz = qaxis([0, 0, 1], psi);
      const [t1, t2] = y;
      const q1 = qmul(qz, qaxis([0, 1, 0], Math.PI / 2 - t1));
      const q2 = qmul(qz, qaxis([0, 1, 0], Math.PI / 2 - t2));
      const d1 = qrot(q1, [1, 0, 0]);
      const d2 = qrot(q2, [1, 0, 0]);
      const c1 = d1.map((c) => 0.5 * c);
      const c2 = d1.map((c, i) => c + 0.5 * d2[i]);
      grow(d1); grow(d1.map((c, i) => c + d2[i])); grow([0, 0, 0]);
      frames.set([...c1, ...q1], o + 1);
      frames.set([...c2, ...q2], o + 8);
      // Beam: six nodes along x at y = 1.5, a travelling wave in z.
      beamSlots.forEach((s, k) => {
        const x = 1.5 + 0.5 * k;
        const p = [x, 1.5, -1 + 0.35 * (k / 5) * Math.sin(2 * Math.PI * 0.8 * t - 1.2 * k)];
        grow(p);
        frames.set([...p, 1, 0, 0, 0], o + 1 + 7 * s);
      });
      // Beam section quantities (after the mesh's values): a travelling axial force
      // wave (signed), a bending moment that follows the curvature of the wave and a
      // small torsion.
      const bOff = o + 1 + 7 * slots + 4 * nNodes;
      for (let e = 0; e < nElements; e++) {
        const ph = 2 * Math.PI * 0.8 * t - 1.2 * (e + 0.5);
        const q = [
          2.0e3 * Math.sin(ph) * (1 - e / nElements),
          Math.hypot(40 * Math.cos(ph) * (e + 0.5) / nElements, 15 * Math.sin(0.7 * t)),
          6 * Math.sin(1.3 * t + e),
        ];
        frames.set(q, bOff + 3 * e);
        q.forEach((v, k) => { beamMax[k] = Math.max(beamMax[k], Math.abs(Math.fround(v))); });
      }
      // Mesh: cantilever bending (fixed at x = -4) and a matching stress field.
      const amp = 0.25 * Math.sin(2 * Math.PI * 0.5 * t);
      const dOff = o + 1 + 7 * slots;
      const vOff = dOff + 3 * nNodes;
      for (let j = 0; j < nNodes; j++) {
        const [x, , z] = mesh.points.slice(3 * j, 3 * j + 3);
        const s = (x + 4) / 2; // 0 at the clamp, 1 at the free end
        const dz = amp * s * s;
        const dx = -amp * 0.3 * s * (z - -1.8);
        frames.set([dx, 0, dz], dOff + 3 * j);
        const vm = 2.5e8 * Math.abs(amp) * (1 - 0.8 * s) * (0.4 + Math.abs(z - -1.8) * 1.2);
        frames[vOff + j] = vm;
        vmMax = Math.max(vmMax, frames[vOff + j]);
        grow([mesh.points[3 * j] + dx, mesh.points[3 * j + 1], mesh.points[3 * j + 2] + dz]);
      }
      f++;
    }
    y = rk4(y, step);
  }
  mesh.vm_max = vmMax;
  grow([0, 0, -2.3]);

  const desc = {
    format: 1,
    model: 'double_pendulum_3d',
    method: 'staggered',
    step,
    duration: 10.0,
    status: 'failed',
    report:
      'step 3001 (t = 3.001 s): Newton iteration did not converge after 50 iterations\n' +
      "  largest constraint violation: joint 'elbow' (index 1), 7.3e-04 m > tolerance 1e-06 m\n" +
      '  residual norm 4.1e-02, last correction 1.7e-01\n' +
      '  hint: reduce the step (--step 0.0005) or use method "monolithic"',
    highlight: { joint: 1 },
    up: [0, 0, 1],
    center: lo.map((c, i) => (c + hi[i]) / 2),
    extent: Math.hypot(...lo.map((c, i) => hi[i] - c)),
    bodies,
    beams: [{
      name: 'arm', nodes: beamSlots, radius: 0.04, elements: nElements,
      n_max: beamMax[0], m_max: beamMax[1], t_max: beamMax[2],
    }],
    joints: [
      { name: 'shoulder', kind: 'revolute', a: null, pa: [0, 0, 0], b: 0, pb: [-0.5, 0, 0], axis: [0, 1, 0] },
      { name: 'elbow', kind: 'revolute', a: 0, pa: [0.5, 0, 0], b: 1, pb: [-0.5, 0, 0], axis: [0, 1, 0] },
    ],
    springs: [{ name: 'tether', a: null, pa: [1.6, -0.6, 0.4], b: 1, pb: [0.5, 0, 0] }],
    planes: [{ name: 'floor', body: null, point: [0, 0, -2.3], normal: [0, 0, 1] }],
    meshes: [mesh],
    frames: { count: F, floats: S, shown_every: every, run_frames: runFrames },
    curves: [
      { name: 'kinetic', unit: 'J', t: curveT, v: kinetic },
      { name: 'potential', unit: 'J', t: curveT, v: potential },
      { name: 'total', unit: 'J', t: curveT, v: total },
      { name: 'energy drift', unit: '', t: curveT, v: drift },
      { name: 'max joint violation', unit: 'm', t: curveT, v: violation },
    ],
  };
  return { desc, frames, title: 'double_pendulum_3d — mbdc view' };
}

/** Zero bodies, no curves, one frame (just the time). */
function emptySample() {
  const desc = {
    format: 1, model: 'empty', method: 'staggered', step: 0.01, duration: 0, status: 'finished',
    report: null, highlight: null, up: [0, 0, 1], center: [0, 0, 0], extent: 0,
    bodies: [], beams: [], joints: [], springs: [], planes: [], meshes: [],
    frames: { count: 1, floats: 1, shown_every: 1, run_frames: 1 }, curves: [],
  };
  return { desc, frames: new Float32Array([0]), title: 'empty' };
}

/** A mesh with bars only (no bodies), y up, finished. */
function meshOnlySample() {
  const mesh = boxMesh([0, 0, 0]);
  mesh.name = 'block';
  const n = mesh.points.length / 3;
  // Add a few bars: a truss on top of the block, using the top nodes.
  mesh.lines = [1, 5, 5, 9, 3, 7, 7, 11, 1, 7, 5, 11];
  const F = 50;
  const S = 1 + 4 * n;
  const frames = new Float32Array(F * S);
  let vmMax = 0;
  for (let f = 0; f < F; f++) {
    const t = f * 0.02;
    frames[f * S] = t;
    for (let j = 0; j < n; j++) {
      const x = mesh.points[3 * j];
      frames[f * S + 1 + 3 * j + 1] = -0.2 * t * (x / 2) ** 2;
      const vm = 1e6 * t * (2 - x);
      frames[f * S + 1 + 3 * n + j] = vm;
      vmMax = Math.max(vmMax, vm);
    }
  }
  mesh.vm_max = vmMax;
  const desc = {
    format: 1, model: 'block', method: 'implicit', step: 0.02, duration: 0.98, status: 'interrupted',
    report: 'interrupted by the user (SIGINT) at t = 0.98 s', highlight: { body: 3 }, // out of range: ignored
    up: [0, 1, 0], center: [1, 0.4, 0.5], extent: 2.5,
    bodies: [], beams: [], joints: [], springs: [], planes: [], meshes: [mesh],
    frames: { count: F, floats: S, shown_every: 1, run_frames: F },
    curves: [{ name: 'strain energy', unit: 'J', t: [0, 0.5, 0.98], v: [0, 1, null] }],
  };
  return { desc, frames, title: 'block' };
}

/** Bodies but zero frames. */
function noFramesSample() {
  const { desc } = fullSample();
  desc.frames = { count: 0, floats: desc.frames.floats, shown_every: 1, run_frames: 0 };
  desc.status = 'unfinished';
  desc.highlight = { body: 1 };
  return { desc, frames: new Float32Array(0), title: 'no frames' };
}

// ---------------------------------------------------------------------------
/** Fill the template exactly as the Rust side does. */
function page({ desc, frames, title }) {
  const tpl = readFileSync(TEMPLATE, 'utf8');
  const bundle = readFileSync(BUNDLE, 'utf8');
  const esc = (s) => s.replace(/&/g, '&amp;').replace(/</g, '&lt;').replace(/>/g, '&gt;');
  const json = JSON.stringify(desc).replace(/<\//g, '<\\/');
  const b64 = Buffer.from(frames.buffer, frames.byteOffset, frames.byteLength).toString('base64');
  const parts = { TITLE: esc(title), DATA: json, FRAMES: b64, VIEWER: bundle };
  let out = tpl;
  for (const [k, v] of Object.entries(parts)) {
    const ph = `{{${k}}}`;
    const i = out.indexOf(ph);
    if (i < 0 || out.indexOf(ph, i + 1) >= 0) throw new Error(`placeholder ${ph} must appear exactly once`);
    out = out.slice(0, i) + v + out.slice(i + ph.length);
  }
  return out;
}

const write = (name, sample) => {
  const path = join(here, name);
  writeFileSync(path, page(sample));
  console.log(`wrote ${path}`);
};
write('sample.html', fullSample());
if (process.argv.includes('--all')) {
  write('sample-empty.html', emptySample());
  write('sample-meshonly.html', meshOnlySample());
  write('sample-noframes.html', noFramesSample());
}
