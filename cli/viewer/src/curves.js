// Curves panel: a 2-D canvas under the 3-D view. Every curve is normalized to
// its own range (shown in the legend with its unit and the value at the
// cursor); a vertical cursor marks the current time; clicking or dragging
// seeks.

import { formatNum } from './colormap.js';

const PALETTE = ['#4e79a7', '#f28e2b', '#e15759', '#76b7b2', '#59a14f', '#edc948', '#b07aa1', '#ff9da7', '#9c755f', '#bab0ac'];
const LEGEND_W = 250;
const PAD = { left: 10, top: 8, bottom: 20 };

/** Index of the last sample with t[i] <= x (or 0). */
function sampleAt(t, x) {
  let lo = 0;
  let hi = t.length - 1;
  if (hi < 0) return -1;
  if (t[hi] <= x) return hi;
  if (t[0] > x) return 0;
  while (hi - lo > 1) {
    const mid = (lo + hi) >> 1;
    if (t[mid] <= x) lo = mid; else hi = mid;
  }
  return lo;
}

/** "Nice" tick step for a span covered by about n ticks. */
function tickStep(span, n) {
  const raw = span / n;
  const p = Math.pow(10, Math.floor(Math.log10(raw)));
  const m = raw / p;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}

/**
 * Create the panel inside `container`; `onSeek(t)` is called on click/drag.
 * Returns {draw(t), resize()} (no-ops when there are no curves).
 */
export function createCurves(container, data, onSeek) {
  const curves = data.desc.curves.map((c, k) => {
    const n = Math.min(c.t.length, c.v.length);
    const num = (x) => (x == null ? NaN : Number(x)); // serde writes NaN as null
    const t = Float64Array.from(c.t.slice(0, n), num);
    const v = Float64Array.from(c.v.slice(0, n), num);
    let lo = Infinity;
    let hi = -Infinity;
    for (let i = 0; i < n; i++) {
      if (isFinite(v[i])) { if (v[i] < lo) lo = v[i]; if (v[i] > hi) hi = v[i]; }
    }
    if (!(hi >= lo)) { lo = 0; hi = 1; }
    // unit "1" (dimensionless) is not shown
    const unit = c.unit == null || String(c.unit) === '1' ? '' : String(c.unit);
    return { name: String(c.name ?? `curve${k}`), unit, t, v, lo, hi, color: PALETTE[k % PALETTE.length] };
  });
  if (curves.length === 0) {
    container.classList.add('empty');
    return { draw() {}, resize() {} };
  }

  // Time axis covers the frames and all curves.
  let t0 = data.F > 0 ? data.time(0) : Infinity;
  let t1 = data.F > 0 ? data.time(data.F - 1) : -Infinity;
  for (const c of curves) {
    if (c.t.length) { t0 = Math.min(t0, c.t[0]); t1 = Math.max(t1, c.t[c.t.length - 1]); }
  }
  if (!isFinite(t0)) t0 = 0;
  if (!(t1 > t0)) t1 = t0 + 1;

  const canvas = document.createElement('canvas');
  container.appendChild(canvas);
  const ctx = canvas.getContext('2d');
  const back = document.createElement('canvas'); // static part: axes and curves
  let W = 0;
  let H = 0;
  let dpr = 1;

  const plotW = () => Math.max(10, W - LEGEND_W - PAD.left);
  const plotH = () => Math.max(10, H - PAD.top - PAD.bottom);
  const xOf = (t) => PAD.left + ((t - t0) / (t1 - t0)) * plotW();
  const tOf = (x) => t0 + ((x - PAD.left) / plotW()) * (t1 - t0);

  function drawStatic() {
    back.width = canvas.width;
    back.height = canvas.height;
    const g = back.getContext('2d');
    g.setTransform(dpr, 0, 0, dpr, 0, 0);
    g.fillStyle = '#fbfbfc';
    g.fillRect(0, 0, W, H);
    const pw = plotW();
    const ph = plotH();
    // Time grid and labels.
    g.strokeStyle = '#e3e6ea';
    g.fillStyle = '#555';
    g.font = '11px sans-serif';
    g.textAlign = 'center';
    g.textBaseline = 'top';
    g.lineWidth = 1;
    const step = tickStep(t1 - t0, Math.max(2, Math.floor(pw / 90)));
    for (let t = Math.ceil(t0 / step) * step; t <= t1 + 1e-9 * step; t += step) {
      const x = Math.round(xOf(t)) + 0.5;
      g.beginPath(); g.moveTo(x, PAD.top); g.lineTo(x, PAD.top + ph); g.stroke();
      g.fillText(`${formatNum(t)} s`, x, PAD.top + ph + 4);
    }
    g.strokeStyle = '#b8bec6';
    g.strokeRect(PAD.left + 0.5, PAD.top + 0.5, pw, ph);
    // Curves, each normalized to its own range; min/max per pixel column when dense.
    for (const c of curves) {
      const n = c.t.length;
      if (n === 0) continue;
      const span = c.hi - c.lo;
      const yOf = (v) => PAD.top + ph - (span > 0 ? (v - c.lo) / span : 0.5) * (ph - 4) - 2;
      g.strokeStyle = c.color;
      g.lineWidth = 1.5;
      g.beginPath();
      let started = false;
      if (n <= 2 * pw) {
        for (let i = 0; i < n; i++) {
          if (!isFinite(c.v[i])) { started = false; continue; }
          const x = xOf(c.t[i]);
          const y = yOf(c.v[i]);
          if (started) g.lineTo(x, y); else { g.moveTo(x, y); started = true; }
        }
      } else {
        let i = 0;
        for (let px = 0; px <= pw && i < n; px++) {
          const tEnd = tOf(PAD.left + px + 1);
          let lo = Infinity;
          let hi = -Infinity;
          while (i < n && c.t[i] < tEnd) {
            if (isFinite(c.v[i])) { lo = Math.min(lo, c.v[i]); hi = Math.max(hi, c.v[i]); }
            i++;
          }
          if (hi < lo) continue;
          const x = PAD.left + px + 0.5;
          if (started) g.lineTo(x, yOf(lo)); else { g.moveTo(x, yOf(lo)); started = true; }
          g.lineTo(x, yOf(hi));
        }
      }
      g.stroke();
    }
  }

  function resize() {
    dpr = window.devicePixelRatio || 1;
    W = Math.max(1, container.clientWidth);
    H = Math.max(1, container.clientHeight);
    canvas.width = Math.round(W * dpr);
    canvas.height = Math.round(H * dpr);
    canvas.style.width = `${W}px`;
    canvas.style.height = `${H}px`;
    drawStatic();
  }

  /** Draw the panel with the cursor at time t. */
  function draw(t) {
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.drawImage(back, 0, 0);
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    const ph = plotH();
    const x = Math.round(xOf(t)) + 0.5;
    ctx.strokeStyle = '#222';
    ctx.lineWidth = 1;
    ctx.beginPath(); ctx.moveTo(x, PAD.top); ctx.lineTo(x, PAD.top + ph); ctx.stroke();
    // Legend: swatch, name [unit], value at the cursor, range.
    const lx = W - LEGEND_W + 8;
    const rowH = Math.min(30, Math.max(14, (H - 6) / curves.length));
    const twoLines = rowH >= 26;
    ctx.textAlign = 'left';
    ctx.textBaseline = 'top';
    curves.forEach((c, k) => {
      const y = 4 + k * rowH;
      if (y + 12 > H) return;
      const i = sampleAt(c.t, t);
      const val = i >= 0 ? c.v[i] : NaN;
      const unit = c.unit ? ` ${c.unit}` : '';
      ctx.fillStyle = c.color;
      ctx.fillRect(lx, y + 2, 10, 10);
      ctx.fillStyle = '#222';
      ctx.font = '12px sans-serif';
      ctx.fillText(`${c.name}: ${formatNum(val)}${unit}`, lx + 15, y);
      if (twoLines) {
        ctx.fillStyle = '#777';
        ctx.font = '10px sans-serif';
        ctx.fillText(`range ${formatNum(c.lo)} … ${formatNum(c.hi)}${unit}`, lx + 15, y + 14);
      }
    });
  }

  // Click or drag to seek.
  let dragging = false;
  const seekAt = (ev) => {
    const r = canvas.getBoundingClientRect();
    const x = ev.clientX - r.left;
    if (x < PAD.left - 4 || x > PAD.left + plotW() + 4) return;
    onSeek(Math.max(t0, Math.min(t1, tOf(x))));
  };
  canvas.addEventListener('pointerdown', (ev) => {
    dragging = true;
    canvas.setPointerCapture(ev.pointerId);
    seekAt(ev);
  });
  canvas.addEventListener('pointermove', (ev) => { if (dragging) seekAt(ev); });
  canvas.addEventListener('pointerup', () => { dragging = false; });
  canvas.addEventListener('pointercancel', () => { dragging = false; });

  resize();
  return { draw, resize };
}
