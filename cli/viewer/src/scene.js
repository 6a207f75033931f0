// Scene building: turns the model description into three.js objects and
// poses them for a given frame (bodies, joints, springs, planes, beams,
// meshes, trails, body axes, camera follow, highlight pulse).

import {
  AmbientLight,
  AxesHelper,
  BoxGeometry,
  BufferAttribute,
  BufferGeometry,
  Color,
  CylinderGeometry,
  DirectionalLight,
  DoubleSide,
  GridHelper,
  Group,
  HemisphereLight,
  Line,
  LineBasicMaterial,
  LineSegments,
  Mesh,
  MeshBasicMaterial,
  MeshStandardMaterial,
  PerspectiveCamera,
  PlaneGeometry,
  Quaternion,
  SRGBColorSpace,
  Scene,
  SphereGeometry,
  Vector3,
  WebGLRenderer,
} from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { DIVERGING, STOPS, colormap } from './colormap.js';

const HIGHLIGHT = new Color('#ff1a1a');
const Y_AXIS = new Vector3(0, 1, 0);
const SPRING_COILS = 8;
const SPRING_SEGMENTS_PER_COIL = 24;

/** Linear-space colour lookup table for a colour map (sequential by default). */
function makeLut(n, stops = STOPS) {
  const lut = new Float32Array(3 * n);
  const rgb = [0, 0, 0];
  const c = new Color();
  for (let i = 0; i < n; i++) {
    colormap(i / (n - 1), rgb, 0, stops);
    c.setRGB(rgb[0], rgb[1], rgb[2], SRGBColorSpace); // converts to linear working space
    lut[3 * i] = c.r; lut[3 * i + 1] = c.g; lut[3 * i + 2] = c.b;
  }
  return lut;
}

/** Bounding radius of a body shape about its mass centre (0 for none). */
function shapeRadius(shape) {
  if (!shape) return 0;
  if (shape.kind === 'sphere') return Number(shape.radius) > 0 ? Number(shape.radius) : 0;
  if (shape.kind === 'box' && Array.isArray(shape.size)) return 0.5 * Math.hypot(...shape.size.map((x) => Number(x) || 0));
  return 0;
}

/**
 * Largest joint-marker radius that does not hide the body: a joint point inside
 * a sphere or box (e.g. at its centre) gets a marker well inside the shape.
 */
function markerCap(shape, p) {
  if (!shape) return Infinity;
  if (shape.kind === 'sphere') {
    const r = Number(shape.radius) || 0;
    return Math.hypot(...p) < r ? 0.6 * r : Infinity;
  }
  if (shape.kind === 'box' && Array.isArray(shape.size)) {
    const half = shape.size.map((x) => 0.5 * (Number(x) || 0));
    const inside = p.every((c, i) => Math.abs(c) < half[i]);
    return inside ? 0.6 * Math.min(...half) : Infinity;
  }
  return Infinity;
}

/** Two unit vectors perpendicular to unit vector e (and to each other). */
function perpendiculars(e, u, v) {
  if (Math.abs(e.x) < 0.9) u.set(1, 0, 0); else u.set(0, 1, 0);
  u.addScaledVector(e, -u.dot(e)).normalize();
  v.crossVectors(e, u);
}

/**
 * Build the scene inside `container` (a positioned element).
 * Returns the controller object used by playback, UI and test hooks.
 */
export function createScene(container, data) {
  const desc = data.desc;
  // Scene size for framing and marker sizes: the data's extent (which covers the
  // mass centres), but at least six times the largest body's bounding radius so
  // that a lone body does not fill the view.
  const L = Math.max(desc.extent, 6 * Math.max(0, ...desc.bodies.map((b) => shapeRadius(b.shape))));
  const slots = data.slots;
  const validSlot = (s) => (Number.isInteger(s) && s >= 0 && s < slots ? s : null);
  const hl = desc.highlight || null;
  const hlBody = hl && hl.body != null ? validSlot(hl.body) : null;
  const hlJoint = hl && hl.joint != null && hl.joint >= 0 && hl.joint < desc.joints.length ? hl.joint : null;

  // --- renderer, camera, controls -------------------------------------------------
  // Transparent clear: the sky-to-ground gradient behind the canvas is CSS (#view).
  const renderer = new WebGLRenderer({ antialias: true, preserveDrawingBuffer: true, alpha: true });
  renderer.setClearColor(0x000000, 0);
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  container.appendChild(renderer.domElement);

  const scene = new Scene();

  const up = new Vector3().fromArray(desc.up);
  if (up.lengthSq() < 1e-12) up.set(0, 0, 1);
  up.normalize();
  const center = new Vector3().fromArray(desc.center);

  const camera = new PerspectiveCamera(40, 1, L * 1e-3, L * 200);
  camera.up.copy(up);
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.enableDamping = false;

  // Home view: from the "front-right-above" of the model, expressed in a basis
  // built around `up` so any up direction gets a sensible view.
  const side = new Vector3();
  const front = new Vector3();
  {
    // Prefer world x as "right" unless up is (nearly) x.
    side.set(1, 0, 0);
    if (Math.abs(side.dot(up)) > 0.9) side.set(0, 1, 0);
    side.addScaledVector(up, -side.dot(up)).normalize();
    front.crossVectors(up, side); // right-handed: side x front = up
  }
  const homeDir = new Vector3()
    .addScaledVector(side, 0.45)
    .addScaledVector(front, -1.0)
    .addScaledVector(up, 0.45)
    .normalize();
  // Distance that fits (a little tightly) a sphere of diameter L in the narrower field of view.
  const homeDist = () => {
    const fovV = (camera.fov * Math.PI) / 180;
    const fovH = 2 * Math.atan(Math.tan(fovV / 2) * camera.aspect);
    return (0.9 * 0.5 * L) / Math.sin(Math.min(fovV, fovH) / 2);
  };

  // --- lights ----------------------------------------------------------------------
  const hemi = new HemisphereLight(0xffffff, 0x8a7f70, 1.6);
  hemi.position.copy(up);
  scene.add(hemi);
  scene.add(new AmbientLight(0xffffff, 0.25));
  const key = new DirectionalLight(0xffffff, 1.8);
  key.position.copy(center).addScaledVector(up, 2 * L).addScaledVector(side, 1.2 * L).addScaledVector(front, -0.8 * L);
  key.target.position.copy(center);
  scene.add(key, key.target);
  const headlight = new DirectionalLight(0xffffff, 0.6); // follows the camera
  camera.add(headlight);
  headlight.position.set(0, 0, 1);
  scene.add(camera);

  // --- world axes at the origin -------------------------------------------------
  const worldAxes = new AxesHelper(0.15 * L);
  scene.add(worldAxes);

  // --- bodies ---------------------------------------------------------------------
  const bodies = desc.bodies.map((b, slot) => {
    const kind = b.shape && b.shape.kind;
    let geom = null;
    let axesSize = 0;
    if (kind === 'box' && Array.isArray(b.shape.size)) {
      const [sx, sy, sz] = b.shape.size.map((x) => Math.max(Number(x) || 0, 1e-6));
      geom = new BoxGeometry(sx, sy, sz);
      axesSize = 0.75 * Math.max(sx, sy, sz);
    } else if (kind === 'sphere' && Number(b.shape.radius) > 0) {
      const r = Number(b.shape.radius);
      geom = new SphereGeometry(r, 32, 16);
      axesSize = 1.6 * r;
    }
    const entry = { slot, name: b.name, color: b.color, mesh: null, axes: null, material: null };
    if (geom) {
      const material = new MeshStandardMaterial({ color: new Color(b.color), roughness: 0.55, metalness: 0.05 });
      const mesh = new Mesh(geom, material);
      mesh.frustumCulled = false;
      const axes = new AxesHelper(axesSize);
      axes.visible = false;
      mesh.add(axes);
      scene.add(mesh);
      Object.assign(entry, { mesh, axes, material });
    }
    return entry;
  });

  // A highlighted body that has no shape of its own (e.g. a beam node) gets a marker.
  let hlMarker = null;
  if (hlBody != null) {
    const b = bodies[hlBody];
    if (b.material) {
      b.material.color.copy(HIGHLIGHT);
      b.material.emissive.copy(HIGHLIGHT);
    } else {
      hlMarker = new Mesh(new SphereGeometry(0.035 * L, 24, 12), new MeshStandardMaterial({ color: HIGHLIGHT, emissive: HIGHLIGHT }));
      scene.add(hlMarker);
    }
  }

  // --- joints ---------------------------------------------------------------------
  const jointR = 0.018 * L;
  const jointGeom = new SphereGeometry(jointR, 20, 10);
  const joints = desc.joints.map((j, k) => {
    const isHl = k === hlJoint;
    const material = new MeshStandardMaterial({
      color: isHl ? HIGHLIGHT : new Color('#2b2b2b'),
      emissive: isHl ? HIGHLIGHT : new Color(0),
      roughness: 0.4,
    });
    const marker = new Mesh(jointGeom, material);
    let r = jointR;
    for (const [s, pt] of [[validSlot(j.a), j.pa], [validSlot(j.b), j.pb]]) {
      if (s != null) r = Math.min(r, markerCap(desc.bodies[s].shape, pt));
    }
    const baseScale = r / jointR;
    marker.scale.setScalar(baseScale * (isHl ? 1.5 : 1));
    scene.add(marker);
    // Line between the a-side and b-side points: zero length when the joint holds.
    const gapGeom = new BufferGeometry();
    gapGeom.setAttribute('position', new BufferAttribute(new Float32Array(6), 3));
    const gap = new Line(gapGeom, new LineBasicMaterial({ color: isHl ? HIGHLIGHT : 0x222222 }));
    gap.frustumCulled = false;
    scene.add(gap);
    let axisLine = null;
    if (Array.isArray(j.axis) && j.axis.length === 3) {
      const g = new BufferGeometry();
      g.setAttribute('position', new BufferAttribute(new Float32Array(6), 3));
      axisLine = new Line(g, new LineBasicMaterial({ color: isHl ? HIGHLIGHT : 0x1f3a93 }));
      axisLine.frustumCulled = false;
      scene.add(axisLine);
    }
    return {
      a: validSlot(j.a), b: validSlot(j.b),
      pa: new Vector3().fromArray(j.pa), pb: new Vector3().fromArray(j.pb),
      axis: axisLine ? new Vector3().fromArray(j.axis).normalize() : null,
      marker, material, gap, axisLine, isHl, baseScale,
    };
  });

  // --- springs --------------------------------------------------------------------
  const springPoints = SPRING_COILS * SPRING_SEGMENTS_PER_COIL + 3;
  const springs = desc.springs.map((s) => {
    const g = new BufferGeometry();
    g.setAttribute('position', new BufferAttribute(new Float32Array(3 * springPoints), 3));
    const line = new Line(g, new LineBasicMaterial({ color: 0x6b4f1d }));
    line.frustumCulled = false;
    scene.add(line);
    return {
      a: validSlot(s.a), b: validSlot(s.b),
      pa: new Vector3().fromArray(s.pa), pb: new Vector3().fromArray(s.pb), line,
    };
  });

  // --- planes -----------------------------------------------------------------------
  const planes = desc.planes.map((p) => {
    const group = new Group();
    const size = 1.4 * L;
    const grid = new GridHelper(size, 22, 0x6f7a86, 0x9aa4ae);
    grid.material.transparent = true;
    grid.material.opacity = 0.6;
    group.add(grid);
    const sheet = new Mesh(
      new PlaneGeometry(size, size).rotateX(-Math.PI / 2),
      new MeshBasicMaterial({ color: 0x8c9aa8, transparent: true, opacity: 0.22, side: DoubleSide, depthWrite: false }),
    );
    group.add(sheet);
    scene.add(group);
    return {
      body: validSlot(p.body),
      point: new Vector3().fromArray(p.point),
      normal: new Vector3().fromArray(p.normal).normalize(),
      group,
    };
  });

  // --- beams (a cylinder per segment plus a sphere per node) ---------------------
  // Segment i is element i (between nodes i and i+1); with section data each segment
  // has its own material, coloured by the beam field, and each node sphere the mean
  // of its segments' colours.
  const cylGeom = new CylinderGeometry(1, 1, 1, 16, 1, true);
  const nodeGeom = new SphereGeometry(1, 16, 8);
  const beams = desc.beams.map((bm, k) => {
    const nodes = bm.nodes.map(validSlot).filter((s) => s != null);
    const r = Number(bm.radius) > 0 ? Number(bm.radius) : 0.01 * L;
    const base = new Color(nodes.length ? desc.bodies[nodes[0]].color : '#999999');
    const material = new MeshStandardMaterial({ color: base, roughness: 0.5, metalness: 0.1 });
    // elements coloured: only those that are segments drawn
    const coloured = Math.min(bm.elements, Math.max(0, nodes.length - 1));
    const segs = [];
    for (let i = 0; i + 1 < nodes.length; i++) {
      const mat = i < coloured ? material.clone() : material;
      const m = new Mesh(cylGeom, mat);
      m.frustumCulled = false;
      scene.add(m);
      segs.push(m);
    }
    const balls = nodes.map((_, i) => {
      const own = coloured > 0 && i <= coloured; // a node of a coloured element
      const m = new Mesh(nodeGeom, own ? material.clone() : material);
      m.scale.setScalar(r);
      m.frustumCulled = false;
      scene.add(m);
      return m;
    });
    return { k, nodes, r, segs, balls, base, coloured };
  });

  // --- meshes (boundary triangles + bar lines, coloured by field) ----------------
  const lut = makeLut(256);
  const lutDiverging = makeLut(256, DIVERGING);
  const meshes = desc.meshes.map((m) => {
    const n = Math.floor(m.points.length / 3);
    const ref = new Float32Array(m.points.slice(0, 3 * n));
    const pos = new BufferAttribute(new Float32Array(ref), 3);
    const col = new BufferAttribute(new Float32Array(3 * n).fill(0.7), 3);
    const entry = { n, ref, pos, col, surface: null, bars: null };
    const tris = m.triangles.filter((i) => Number.isInteger(i) && i >= 0 && i < n);
    if (tris.length >= 3) {
      const g = new BufferGeometry();
      g.setAttribute('position', pos);
      g.setAttribute('color', col);
      g.setIndex(tris.slice(0, tris.length - (tris.length % 3)));
      const mat = new MeshStandardMaterial({
        vertexColors: true, flatShading: true, side: DoubleSide, roughness: 0.7, metalness: 0.0,
        polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1,
      });
      entry.surface = new Mesh(g, mat);
      entry.surface.frustumCulled = false;
      scene.add(entry.surface);
    }
    const lines = m.lines.filter((i) => Number.isInteger(i) && i >= 0 && i < n);
    if (lines.length >= 2) {
      const g = new BufferGeometry();
      g.setAttribute('position', pos);
      g.setAttribute('color', col);
      g.setIndex(lines.slice(0, lines.length - (lines.length % 2)));
      entry.bars = new LineSegments(g, new LineBasicMaterial({ vertexColors: true }));
      entry.bars.frustumCulled = false;
      scene.add(entry.bars);
    }
    return entry;
  });

  // --- trails -------------------------------------------------------------------------
  const trails = new Map(); // slot -> Line

  // --- state & helpers ----------------------------------------------------------------
  let frame = 0;
  let field = data.vmMax > 0 ? 'vm' : data.dispMax > 0 ? 'disp' : 'none';
  const bmax = data.beamMax;
  let beamField = !data.hasBeamSections ? 'none'
    : bmax.bending > 0 ? 'bending' : bmax.axial > 0 ? 'axial' : bmax.torsion > 0 ? 'torsion' : 'none';
  let follow = null;
  const tmpP = [0, 0, 0];
  const tmpQ = [1, 0, 0, 0];
  const vA = new Vector3();
  const vB = new Vector3();
  const vU = new Vector3();
  const vV = new Vector3();
  const vE = new Vector3();
  const qB = new Quaternion();

  /** World position of slot s at the current frame. */
  function bodyPos(s, out) {
    data.position(frame, s, tmpP);
    return out.set(tmpP[0], tmpP[1], tmpP[2]);
  }
  /** Orientation (body->world) of slot s at the current frame. */
  function bodyQuat(s, out) {
    data.quaternion(frame, s, tmpQ);
    out.set(tmpQ[1], tmpQ[2], tmpQ[3], tmpQ[0]); // three.js order is x, y, z, w
    const l = out.length();
    if (l > 1e-12) out.set(out.x / l, out.y / l, out.z / l, out.w / l); else out.identity();
    return out;
  }
  /** World position of point p given in the frame of slot s (world if s is null). */
  function worldPoint(s, p, out) {
    if (s == null) return out.copy(p);
    bodyQuat(s, qB);
    bodyPos(s, out);
    return out.add(vE.copy(p).applyQuaternion(qB));
  }

  function setLine2(line, a, b) {
    const arr = line.geometry.attributes.position;
    arr.setXYZ(0, a.x, a.y, a.z);
    arr.setXYZ(1, b.x, b.y, b.z);
    arr.needsUpdate = true;
  }

  function updateSpring(sp) {
    worldPoint(sp.a, sp.pa, vA);
    worldPoint(sp.b, sp.pb, vB);
    const attr = sp.line.geometry.attributes.position;
    const d = vE.subVectors(vB, vA);
    const len = d.length();
    if (len < 1e-12) {
      for (let i = 0; i < springPoints; i++) attr.setXYZ(i, vA.x, vA.y, vA.z);
      attr.needsUpdate = true;
      return;
    }
    const e = d.clone().divideScalar(len);
    perpendiculars(e, vU, vV);
    const r = Math.min(0.02 * L, 0.25 * len + 0.004 * L);
    const lead = 0.1; // straight lead-in and lead-out (fraction of length)
    attr.setXYZ(0, vA.x, vA.y, vA.z);
    const nc = springPoints - 2;
    for (let i = 0; i < nc; i++) {
      const f = i / (nc - 1);
      const th = 2 * Math.PI * SPRING_COILS * f;
      const s = (lead + (1 - 2 * lead) * f) * len;
      const c = Math.cos(th) * r;
      const sn = Math.sin(th) * r;
      attr.setXYZ(
        i + 1,
        vA.x + e.x * s + vU.x * c + vV.x * sn,
        vA.y + e.y * s + vU.y * c + vV.y * sn,
        vA.z + e.z * s + vU.z * c + vV.z * sn,
      );
    }
    attr.setXYZ(springPoints - 1, vB.x, vB.y, vB.z);
    attr.needsUpdate = true;
  }

  function updatePlane(pl) {
    // Plane point and normal in world, grid centred at the projection of the model centre.
    const n = vU.copy(pl.normal);
    const p = vA.copy(pl.point);
    if (pl.body != null) {
      bodyQuat(pl.body, qB);
      n.applyQuaternion(qB);
      p.applyQuaternion(qB).add(bodyPos(pl.body, vB));
    }
    const c = vB.copy(center).addScaledVector(n, -vE.subVectors(center, p).dot(n));
    pl.group.position.copy(c);
    pl.group.quaternion.setFromUnitVectors(Y_AXIS, n);
  }

  function updateMesh(me, k) {
    const { n, ref, pos, col } = me;
    const fl = data.floats;
    const d = data.dispOffset(frame, k);
    const v = data.vmOffset(frame, k);
    const pa = pos.array;
    const ca = col.array;
    const dmax = data.dispMax > 0 ? data.dispMax : 1;
    const vmax = data.vmMax > 0 ? data.vmMax : 1;
    for (let j = 0; j < n; j++) {
      const dx = d >= 0 ? fl[d + 3 * j] : 0;
      const dy = d >= 0 ? fl[d + 3 * j + 1] : 0;
      const dz = d >= 0 ? fl[d + 3 * j + 2] : 0;
      pa[3 * j] = ref[3 * j] + dx;
      pa[3 * j + 1] = ref[3 * j + 1] + dy;
      pa[3 * j + 2] = ref[3 * j + 2] + dz;
      if (field === 'none') {
        ca[3 * j] = 0.62; ca[3 * j + 1] = 0.65; ca[3 * j + 2] = 0.7;
        continue;
      }
      let u;
      if (field === 'vm') u = v >= 0 ? fl[v + j] / vmax : 0;
      else u = Math.sqrt(dx * dx + dy * dy + dz * dz) / dmax;
      const li = 3 * Math.max(0, Math.min(255, Math.round(u * 255) || 0));
      ca[3 * j] = lut[li]; ca[3 * j + 1] = lut[li + 1]; ca[3 * j + 2] = lut[li + 2];
    }
    pos.needsUpdate = true;
    col.needsUpdate = true;
  }

  const NO_DATA = new Color(0.62, 0.65, 0.7); // an element without a value (NaN)
  const BEAM_Q = { axial: 0, bending: 1, torsion: 2 };

  /** Colour the segments and node spheres of beam bm for the current frame. */
  function colourBeam(bm) {
    if (bm.coloured === 0) return;
    const q = BEAM_Q[beamField];
    const o = q == null ? -1 : data.beamOffset(frame, bm.k);
    const fl = data.floats;
    const max = q == null ? 0 : data.beamMax[beamField];
    for (let i = 0; i < bm.coloured; i++) {
      const c = bm.segs[i].material.color;
      if (q == null) { c.copy(bm.base); continue; }
      const v = o >= 0 ? fl[o + 3 * i + q] : NaN;
      if (!Number.isFinite(v)) { c.copy(NO_DATA); continue; }
      let li;
      if (q === 1) {
        const u = max > 0 ? v / max : 0;
        li = 3 * Math.max(0, Math.min(255, Math.round(u * 255) || 0));
        c.setRGB(lut[li], lut[li + 1], lut[li + 2]);
      } else {
        const u = max > 0 ? 0.5 + 0.5 * (v / max) : 0.5;
        li = 3 * Math.max(0, Math.min(255, Math.round(u * 255) || 0));
        c.setRGB(lutDiverging[li], lutDiverging[li + 1], lutDiverging[li + 2]);
      }
    }
    bm.balls.forEach((ball, i) => {
      if (i > bm.coloured) return; // shares the beam's material
      const c = ball.material.color;
      const a = i - 1 >= 0 && i - 1 < bm.coloured ? bm.segs[i - 1].material.color : null;
      const b = i < bm.coloured ? bm.segs[i].material.color : null;
      if (a && b) c.copy(a).lerp(b, 0.5);
      else if (a || b) c.copy(a || b);
    });
  }

  /** Pose everything for frame i. */
  function setFrame(i) {
    frame = data.F > 0 ? Math.max(0, Math.min(data.F - 1, i | 0)) : 0;
    for (const b of bodies) {
      if (!b.mesh) continue;
      bodyPos(b.slot, b.mesh.position);
      bodyQuat(b.slot, b.mesh.quaternion);
    }
    if (hlMarker) bodyPos(hlBody, hlMarker.position);
    for (const j of joints) {
      worldPoint(j.a, j.pa, vA);
      worldPoint(j.b, j.pb, vB);
      j.marker.position.copy(vA);
      setLine2(j.gap, vA, vB);
      if (j.axisLine) {
        const ax = vU.copy(j.axis);
        if (j.b != null) ax.applyQuaternion(bodyQuat(j.b, qB));
        const h = 0.06 * L;
        setLine2(j.axisLine, vV.copy(vA).addScaledVector(ax, -h), vE.copy(vA).addScaledVector(ax, h));
      }
    }
    springs.forEach(updateSpring);
    planes.forEach(updatePlane);
    for (const bm of beams) {
      bm.nodes.forEach((s, i) => bodyPos(s, bm.balls[i].position));
      for (let i = 0; i < bm.segs.length; i++) {
        const a = bm.balls[i].position;
        const b = bm.balls[i + 1].position;
        const seg = bm.segs[i];
        const d = vE.subVectors(b, a);
        const len = d.length();
        seg.position.addVectors(a, b).multiplyScalar(0.5);
        if (len > 1e-12) seg.quaternion.setFromUnitVectors(Y_AXIS, d.divideScalar(len));
        seg.scale.set(bm.r, Math.max(len, 1e-9), bm.r);
      }
      colourBeam(bm);
    }
    meshes.forEach(updateMesh);
    for (const [, line] of trails) line.geometry.setDrawRange(0, frame + 1);
    if (follow != null) {
      const p = bodyPos(follow, vA);
      const delta = vB.subVectors(p, controls.target);
      camera.position.add(delta);
      controls.target.copy(p);
      controls.update();
    }
  }

  /** Pulse the highlighted body or joint; `seconds` is wall-clock time. */
  function pulse(seconds) {
    const s = 0.5 + 0.5 * Math.sin(seconds * 2 * Math.PI * 1.2);
    if (hlBody != null && bodies[hlBody].material) bodies[hlBody].material.emissiveIntensity = 0.15 + 0.75 * s;
    if (hlMarker) hlMarker.scale.setScalar(0.8 + 0.5 * s);
    for (const j of joints) {
      if (!j.isHl) continue;
      j.material.emissiveIntensity = 0.2 + 0.8 * s;
      j.marker.scale.setScalar(j.baseScale * (1.2 + 0.6 * s));
    }
  }

  function resetView() {
    const target = follow != null ? bodyPos(follow, new Vector3()) : center.clone();
    controls.target.copy(target);
    camera.position.copy(target).addScaledVector(homeDir, homeDist());
    camera.up.copy(up);
    controls.update();
  }

  function resize() {
    const w = Math.max(1, container.clientWidth);
    const h = Math.max(1, container.clientHeight);
    renderer.setSize(w, h);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
  }

  function render() {
    renderer.render(scene, camera);
  }

  function setFollow(slot) {
    follow = validSlot(slot);
    if (follow != null) {
      const p = bodyPos(follow, vA);
      camera.position.add(vB.subVectors(p, controls.target));
      controls.target.copy(p);
      controls.update();
    }
  }

  function setTrail(slot, on) {
    slot = validSlot(slot);
    if (slot == null) return;
    if (!on) {
      const line = trails.get(slot);
      if (line) {
        scene.remove(line);
        line.geometry.dispose();
        line.material.dispose();
        trails.delete(slot);
      }
      return;
    }
    if (trails.has(slot) || data.F === 0) return;
    const arr = new Float32Array(3 * data.F);
    for (let i = 0; i < data.F; i++) {
      data.position(i, slot, tmpP);
      arr[3 * i] = tmpP[0]; arr[3 * i + 1] = tmpP[1]; arr[3 * i + 2] = tmpP[2];
    }
    const g = new BufferGeometry();
    g.setAttribute('position', new BufferAttribute(arr, 3));
    g.setDrawRange(0, frame + 1);
    const line = new Line(g, new LineBasicMaterial({ color: new Color(desc.bodies[slot].color) }));
    line.frustumCulled = false;
    scene.add(line);
    trails.set(slot, line);
  }

  function setAxes(on) {
    for (const b of bodies) if (b.axes) b.axes.visible = !!on;
  }

  function setField(f) {
    field = f === 'vm' || f === 'disp' ? f : 'none';
    meshes.forEach(updateMesh);
  }

  function setBeamField(f) {
    beamField = data.hasBeamSections && (f === 'axial' || f === 'bending' || f === 'torsion') ? f : 'none';
    beams.forEach(colourBeam);
  }

  /** Screen positions (CSS px, viewport origin) of drawn bodies' mass centres. */
  function projectBodies() {
    const rect = renderer.domElement.getBoundingClientRect();
    const v = new Vector3();
    const out = [];
    for (const b of bodies) {
      if (!b.mesh) continue;
      v.copy(b.mesh.position).project(camera);
      const x = rect.left + ((v.x + 1) / 2) * rect.width;
      const y = rect.top + ((1 - v.y) / 2) * rect.height;
      // colour as drawn: the highlighted body is red
      const isHl = b.slot === hlBody;
      const entry = { name: b.name, px: [Math.round(x * 10) / 10, Math.round(y * 10) / 10], color: '#' + (isHl ? HIGHLIGHT : new Color(b.color)).getHexString() };
      if (isHl) entry.highlight = true;
      out.push(entry);
    }
    return out;
  }

  resize();
  resetView();
  setFrame(0);

  return {
    renderer, camera, controls,
    get frame() { return frame; },
    get field() { return field; },
    get beamField() { return beamField; },
    hasMeshes: meshes.length > 0,
    hasBeamSections: data.hasBeamSections,
    setFrame, render, resize, resetView, pulse, setFollow, setTrail, setAxes, setField, setBeamField, projectBodies,
    hasHighlight: hlBody != null || hlJoint != null,
  };
}
