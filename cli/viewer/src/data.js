// Data decoding: reads the two <script> blocks the Rust side fills in
// (`mbdc-view-data`, JSON; `mbdc-view-frames`, base64 little-endian Float32)
// and exposes a small, defensive accessor object over them.
//
// Frame layout (S floats per frame, F frames, frame after frame):
//   t
//   per body slot:          x y z qw qx qy qz   (mass centre, body->world)
//   per mesh, per node:     dx dy dz            (displacement from reference)
//   per mesh, per node:     von_mises           (Pa, nodal)
//   per beam, per element:  N1 |M| M1           (N, N·m, N·m; |M| = sqrt(M2² + M3²))
// so S = 1 + 7*slots + sum_mesh 4*nodes + sum_beam 3*elements.

/** Warnings found while decoding (shown on screen, not treated as errors). */
export const warnings = [];

/** Read and parse the JSON model description. */
function readJson(id) {
  const el = document.getElementById(id);
  if (!el) throw new Error(`missing <script id="${id}">`);
  return JSON.parse(el.textContent);
}

/** Decode base64 text into a Float32Array (little-endian on any host). */
function decodeFloats(text) {
  const clean = text.replace(/[^A-Za-z0-9+/=]/g, '');
  if (clean.length === 0) return new Float32Array(0);
  const bin = atob(clean);
  const n = Math.floor(bin.length / 4);
  const bytes = new Uint8Array(n * 4);
  for (let i = 0; i < n * 4; i++) bytes[i] = bin.charCodeAt(i);
  const littleHost = new Uint8Array(new Uint32Array([1]).buffer)[0] === 1;
  if (littleHost) return new Float32Array(bytes.buffer);
  // Big-endian host (rare): go through a DataView.
  const view = new DataView(bytes.buffer);
  const out = new Float32Array(n);
  for (let i = 0; i < n; i++) out[i] = view.getFloat32(i * 4, true);
  return out;
}

/** Give every optional field of the description a safe default. */
function normalize(d) {
  const arr = (x) => (Array.isArray(x) ? x : []);
  const vec = (x, def) => (Array.isArray(x) && x.length === 3 ? x.map(Number) : def);
  d.bodies = arr(d.bodies).map((b, i) => ({
    name: b && b.name != null ? String(b.name) : `body${i}`,
    shape: (b && b.shape) || { kind: 'none' },
    color: (b && b.color) || '#888888',
  }));
  const count = (x) => (Number.isInteger(x) && x > 0 ? x : 0);
  const maxOf = (x) => (Number(x) > 0 ? Number(x) : 0);
  d.beams = arr(d.beams).map((b) => ({
    ...b,
    nodes: arr(b && b.nodes),
    elements: count(b && b.elements),
    n_max: maxOf(b && b.n_max),
    m_max: maxOf(b && b.m_max),
    t_max: maxOf(b && b.t_max),
  }));
  d.joints = arr(d.joints).map((j) => ({ ...j, pa: vec(j.pa, [0, 0, 0]), pb: vec(j.pb, [0, 0, 0]) }));
  d.springs = arr(d.springs).map((s) => ({ ...s, pa: vec(s.pa, [0, 0, 0]), pb: vec(s.pb, [0, 0, 0]) }));
  d.planes = arr(d.planes).map((p) => ({ ...p, point: vec(p.point, [0, 0, 0]), normal: vec(p.normal, [0, 0, 1]) }));
  d.meshes = arr(d.meshes).map((m) => ({
    ...m,
    points: arr(m.points),
    triangles: arr(m.triangles),
    lines: arr(m.lines),
    vm_max: Number(m.vm_max) || 0,
  }));
  d.curves = arr(d.curves).filter((c) => c && Array.isArray(c.t) && Array.isArray(c.v));
  d.up = vec(d.up, [0, 0, 1]);
  d.center = vec(d.center, [0, 0, 0]);
  d.extent = Number(d.extent) > 0 ? Number(d.extent) : 1;
  d.frames = d.frames || {};
  d.status = d.status || 'unfinished';
  return d;
}

/**
 * Load everything. Returns an object with the description (`desc`) and frame
 * accessors. All accessors are safe to call with zero frames.
 */
export function loadData() {
  const desc = normalize(readJson('mbdc-view-data'));
  const framesEl = document.getElementById('mbdc-view-frames');
  const floats = decodeFloats(framesEl ? framesEl.textContent : '');

  const slots = desc.bodies.length;
  // Offsets of each mesh's displacement and von Mises blocks within a frame.
  let off = 1 + 7 * slots;
  const meshDisp = [];
  for (const m of desc.meshes) {
    meshDisp.push(off);
    off += 3 * Math.floor(m.points.length / 3);
  }
  const meshVm = [];
  for (const m of desc.meshes) {
    meshVm.push(off);
    off += Math.floor(m.points.length / 3);
  }
  // Offsets of each beam's section quantities (3 floats per element).
  const beamSec = [];
  for (const b of desc.beams) {
    beamSec.push(off);
    off += 3 * b.elements;
  }
  const S = off;
  if (desc.frames.floats != null && desc.frames.floats !== S) {
    warnings.push(`frame size ${desc.frames.floats} floats, expected ${S} from the model description`);
  }
  let F = Math.floor(floats.length / S);
  if (desc.frames.count != null && desc.frames.count !== F) {
    warnings.push(`${F} frames decoded, header says ${desc.frames.count}`);
  }
  if (F === 0) warnings.push('no frames');

  const data = {
    desc,
    floats,
    S,
    F,
    slots,
    /** Simulation time of frame i. */
    time(i) {
      return F > 0 ? floats[i * S] : 0;
    },
    /** Position of body slot s at frame i, written into `out` (3 numbers). */
    position(i, s, out) {
      if (F === 0) { out[0] = out[1] = out[2] = 0; return out; }
      const o = i * S + 1 + 7 * s;
      out[0] = floats[o]; out[1] = floats[o + 1]; out[2] = floats[o + 2];
      return out;
    },
    /** Quaternion (w, x, y, z) of body slot s at frame i, written into `out`. */
    quaternion(i, s, out) {
      if (F === 0) { out[0] = 1; out[1] = out[2] = out[3] = 0; return out; }
      const o = i * S + 1 + 7 * s + 3;
      out[0] = floats[o]; out[1] = floats[o + 1]; out[2] = floats[o + 2]; out[3] = floats[o + 3];
      return out;
    },
    /** Float offset of mesh m's displacement block in frame i (or -1). */
    dispOffset(i, m) {
      return F > 0 ? i * S + meshDisp[m] : -1;
    },
    /** Float offset of mesh m's von Mises block in frame i (or -1). */
    vmOffset(i, m) {
      return F > 0 ? i * S + meshVm[m] : -1;
    },
    /**
     * Float offset of beam b's section quantities in frame i (element e's N1, |M|, M1
     * at +3e, +3e+1, +3e+2), or -1 when there are none.
     */
    beamOffset(i, b) {
      return F > 0 && desc.beams[b].elements > 0 ? i * S + beamSec[b] : -1;
    },
    /** Index of the frame whose time is nearest to t. */
    nearestFrame(t) {
      if (F <= 1) return 0;
      let lo = 0;
      let hi = F - 1;
      while (hi - lo > 1) {
        const mid = (lo + hi) >> 1;
        if (floats[mid * S] <= t) lo = mid; else hi = mid;
      }
      return Math.abs(floats[hi * S] - t) < Math.abs(floats[lo * S] - t) ? hi : lo;
    },
    /** Index of the last frame whose time is <= t (0 if none). */
    frameAtOrBefore(t) {
      if (F <= 1) return 0;
      let lo = 0;
      let hi = F - 1;
      if (floats[hi * S] <= t) return hi;
      while (hi - lo > 1) {
        const mid = (lo + hi) >> 1;
        if (floats[mid * S] <= t) lo = mid; else hi = mid;
      }
      return lo;
    },
  };

  // Field ranges over all shown frames (one colour bar for all meshes).
  let dispMax = 0;
  let vmMax = 0;
  desc.meshes.forEach((m, k) => {
    const n = Math.floor(m.points.length / 3);
    for (let i = 0; i < F; i++) {
      const d = data.dispOffset(i, k);
      for (let j = 0; j < n; j++) {
        const x = floats[d + 3 * j], y = floats[d + 3 * j + 1], z = floats[d + 3 * j + 2];
        const a = Math.sqrt(x * x + y * y + z * z);
        if (a > dispMax) dispMax = a;
      }
      if (!(m.vm_max > 0)) {
        const v = data.vmOffset(i, k);
        for (let j = 0; j < n; j++) if (floats[v + j] > vmMax) vmMax = floats[v + j];
      }
    }
    if (m.vm_max > vmMax) vmMax = m.vm_max;
  });
  data.dispMax = dispMax;
  data.vmMax = vmMax;

  // Beam field ranges (largest |value| over the shown frames, one range for all beams):
  // from the description, or from the frames when it does not give them.
  const beamMax = { axial: 0, bending: 0, torsion: 0 };
  const keys = [['axial', 'n_max'], ['bending', 'm_max'], ['torsion', 't_max']];
  desc.beams.forEach((b, k) => {
    keys.forEach(([f, key], q) => {
      let m = b[key];
      if (!(m > 0)) {
        for (let i = 0; i < F; i++) {
          const o = data.beamOffset(i, k);
          for (let e = 0; o >= 0 && e < b.elements; e++) {
            const v = Math.abs(floats[o + 3 * e + q]);
            if (v > m) m = v;
          }
        }
      }
      if (m > beamMax[f]) beamMax[f] = m;
    });
  });
  data.beamMax = beamMax;
  data.hasBeamSections = desc.beams.some((b) => b.elements > 0);
  return data;
}
