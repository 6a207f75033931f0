// Overlays on the 3-D view: the info line (model, method, step, status,
// decimation, decoding warnings), the report box for runs that did not
// finish, and the colour bars of the mesh field and of the beam field.

import { DIVERGING, cssGradient, formatSI } from './colormap.js';
import { warnings } from './data.js';

const STATUS_TITLE = {
  failed: 'Run failed',
  interrupted: 'Run interrupted',
  unfinished: 'Run unfinished',
};

function text(tag, cls, content) {
  const el = document.createElement(tag);
  if (cls) el.className = cls;
  if (content != null) el.textContent = content;
  return el;
}

/** Fill the info line and the report box. */
export function showInfo(data) {
  const d = data.desc;
  const info = document.getElementById('info');
  if (info) {
    info.textContent = '';
    const parts = [];
    if (d.model) parts.push(text('b', null, String(d.model)));
    if (d.method) parts.push(text('span', null, `method ${d.method}`));
    if (Number(d.step) > 0) parts.push(text('span', null, `step ${formatSI(Number(d.step), 's')}`));
    if (Number(d.duration) > 0) parts.push(text('span', null, `duration ${formatSI(Number(d.duration), 's')}`));
    parts.push(text('span', `status status-${d.status}`, String(d.status)));
    const fr = d.frames || {};
    if (Number(fr.shown_every) > 1) {
      const k = Number(fr.shown_every);
      const total = fr.run_frames != null ? fr.run_frames : '?';
      parts.push(text('span', 'decimated', `showing every ${k}${ordinal(k)} of ${total} frames`));
    }
    for (const w of warnings) parts.push(text('span', 'warning', `⚠ ${w}`));
    parts.forEach((p, i) => {
      if (i > 0) info.appendChild(document.createTextNode(' · '));
      info.appendChild(p);
    });
  }

  const box = document.getElementById('report');
  if (box && d.status !== 'finished') {
    const last = data.F > 0 ? data.time(data.F - 1) : 0;
    box.querySelector('.title').textContent = STATUS_TITLE[d.status] || `Run ${d.status}`;
    box.querySelector('.ends').textContent = `replay ends at t = ${last.toPrecision(6)} s`;
    box.querySelector('pre').textContent = d.report ? String(d.report) : '(no report)';
    box.hidden = false;
    const toggle = box.querySelector('button');
    toggle.addEventListener('click', () => {
      box.classList.toggle('collapsed');
      toggle.textContent = box.classList.contains('collapsed') ? '+' : '−';
    });
  }
}

function ordinal(k) {
  const t = k % 100;
  if (t >= 11 && t <= 13) return 'th';
  return { 1: 'st', 2: 'nd', 3: 'rd' }[k % 10] || 'th';
}

/** Show or hide the colour bar for field 'vm' | 'disp' | 'none'. */
export function showColorBar(data, field) {
  const bar = document.getElementById('colorbar');
  if (!bar) return;
  if (data.desc.meshes.length === 0 || field === 'none') {
    bar.hidden = true;
    return;
  }
  bar.hidden = false;
  bar.querySelector('.ramp').style.background = cssGradient();
  const isVm = field === 'vm';
  bar.querySelector('.name').textContent = isVm ? 'von Mises' : '|displacement|';
  bar.querySelector('.max').textContent = formatSI(isVm ? data.vmMax : data.dispMax, isVm ? 'Pa' : 'm');
  bar.querySelector('.min').textContent = formatSI(0, isVm ? 'Pa' : 'm');
  bar.querySelector('.mid').textContent = '';
}

/** Beam fields: colour-bar title, unit, whether signed (diverging map, range +-max). */
const BEAM_FIELDS = {
  axial: ['beam axial N₁', 'N', true],
  bending: ['beam bending |M|', 'N·m', false],
  torsion: ['beam torsion M₁', 'N·m', true],
};

/** Show or hide the colour bar for the beam field 'axial' | 'bending' | 'torsion' | 'none'. */
export function showBeamBar(data, field) {
  const bar = document.getElementById('beambar');
  if (!bar) return;
  const f = BEAM_FIELDS[field];
  if (!data.hasBeamSections || !f) {
    bar.hidden = true;
    return;
  }
  const [name, unit, signed] = f;
  const max = data.beamMax[field] || 0;
  bar.hidden = false;
  bar.querySelector('.ramp').style.background = cssGradient(signed ? DIVERGING : undefined);
  bar.querySelector('.name').textContent = name;
  bar.querySelector('.max').textContent = formatSI(max, unit);
  bar.querySelector('.mid').textContent = signed ? formatSI(0, unit) : '';
  bar.querySelector('.min').textContent = formatSI(signed ? -max : 0, unit);
}
