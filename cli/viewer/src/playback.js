// Playback and controls UI: play/pause, speed, scrub bar and time label,
// frame stepping, follow, trails, body axes, mesh field, beam field, reset view, keyboard
// shortcuts, and the animation loop that renders on demand.

import { showBeamBar, showColorBar } from './overlay.js';

const SPEEDS = [0.1, 0.2, 0.5, 1, 2, 5, 10];

function $(id) {
  return document.getElementById(id);
}

function option(value, label) {
  const o = document.createElement('option');
  o.value = value;
  o.textContent = label;
  return o;
}

/**
 * Wire the controls bar to the scene `view` and the curves panel.
 * `opts` comes from the URL hash: {t, follow, trails, axes, field, beamfield, speed}.
 * `afterRender(playing)` is called after every render (test hooks).
 * Returns {applyOptions(opts), seekTime(t)}.
 */
export function startPlayback(view, data, curves, opts, afterRender) {
  const F = data.F;
  const desc = data.desc;
  const state = {
    playing: opts.t == null && F > 1,
    speed: 1, // simulation seconds per wall-clock second, or 'frame'
    simTime: data.time(0),
    dirty: true,
  };

  // Decimals for the time label from the typical frame spacing.
  const dtFrame = F > 1 ? (data.time(F - 1) - data.time(0)) / (F - 1) : Number(desc.step) || 1e-3;
  const decimals = Math.min(6, Math.max(2, Math.ceil(-Math.log10(dtFrame > 0 ? dtFrame : 1e-3))));
  const tEnd = data.time(Math.max(0, F - 1));

  // --- controls -----------------------------------------------------------------------
  const playBtn = $('play');
  const scrub = $('scrub');
  const timeLabel = $('time');
  scrub.min = 0;
  scrub.max = Math.max(0, F - 1);
  scrub.step = 1;
  scrub.disabled = F <= 1;

  const speedSel = $('speed');
  for (const s of SPEEDS) speedSel.appendChild(option(String(s), `${s}×`));
  speedSel.appendChild(option('frame', 'every frame'));
  speedSel.value = '1';
  if (opts.speed && [...speedSel.options].some((o) => o.value === opts.speed)) speedSel.value = opts.speed;
  state.speed = speedSel.value === 'frame' ? 'frame' : Number(speedSel.value);

  const followSel = $('follow');
  followSel.appendChild(option('', 'none'));
  desc.bodies.forEach((b, i) => followSel.appendChild(option(String(i), b.name)));

  // Trails: a checkbox per body (drawn bodies first, then beam nodes etc.).
  const trailList = $('trail-list');
  const trailBoxes = [];
  const order = desc.bodies.map((b, i) => i);
  order.sort((a, b) => (desc.bodies[a].shape.kind === 'none') - (desc.bodies[b].shape.kind === 'none') || a - b);
  for (const i of order) {
    const label = document.createElement('label');
    const box = document.createElement('input');
    box.type = 'checkbox';
    box.addEventListener('change', () => {
      view.setTrail(i, box.checked);
      state.dirty = true;
    });
    trailBoxes[i] = box;
    label.append(box, ` ${desc.bodies[i].name}`);
    trailList.appendChild(label);
  }
  if (desc.bodies.length === 0) trailList.textContent = 'no bodies';

  const axesBox = $('axes');
  const fieldSel = $('field');
  if (view.hasMeshes) {
    fieldSel.append(option('vm', 'von Mises'), option('disp', '|displacement|'), option('none', 'none'));
    fieldSel.value = view.field;
  } else {
    $('field-wrap').hidden = true;
  }
  const beamSel = $('beamfield');
  if (view.hasBeamSections) {
    beamSel.append(option('axial', 'axial N₁'), option('bending', 'bending |M|'), option('torsion', 'torsion M₁'), option('none', 'none'));
    beamSel.value = view.beamField;
  } else {
    $('beamfield-wrap').hidden = true;
  }

  // --- actions ----------------------------------------------------------------------
  function showFrame(i) {
    view.setFrame(i);
    state.dirty = true;
  }
  function seekFrame(i) {
    showFrame(i);
    state.simTime = data.time(view.frame);
  }
  function setPlaying(p) {
    if (p && view.frame >= F - 1) seekFrame(0); // play from the end restarts
    state.playing = p && F > 1;
    state.simTime = data.time(view.frame);
    playBtn.textContent = state.playing ? '❚❚' : '▶';
    playBtn.title = state.playing ? 'Pause (space)' : 'Play (space)';
  }
  function step(d) {
    setPlaying(false);
    seekFrame(view.frame + d);
  }

  playBtn.addEventListener('click', () => setPlaying(!state.playing));
  $('back').addEventListener('click', () => step(-1));
  $('fwd').addEventListener('click', () => step(1));
  $('first').addEventListener('click', () => { setPlaying(false); seekFrame(0); });
  $('last').addEventListener('click', () => { setPlaying(false); seekFrame(F - 1); });
  scrub.addEventListener('input', () => seekFrame(Number(scrub.value)));
  speedSel.addEventListener('change', () => {
    state.speed = speedSel.value === 'frame' ? 'frame' : Number(speedSel.value);
    state.simTime = data.time(view.frame);
  });
  followSel.addEventListener('change', () => {
    view.setFollow(followSel.value === '' ? null : Number(followSel.value));
    state.dirty = true;
  });
  axesBox.addEventListener('change', () => {
    view.setAxes(axesBox.checked);
    state.dirty = true;
  });
  fieldSel.addEventListener('change', () => {
    view.setField(fieldSel.value);
    showColorBar(data, view.field);
    state.dirty = true;
  });
  beamSel.addEventListener('change', () => {
    view.setBeamField(beamSel.value);
    showBeamBar(data, view.beamField);
    state.dirty = true;
  });
  $('reset').addEventListener('click', () => {
    view.resetView();
    state.dirty = true;
  });
  view.controls.addEventListener('change', () => { state.dirty = true; });

  // Keyboard: space play/pause, arrows step, Home/End, r reset view.
  window.addEventListener('keydown', (ev) => {
    if (ev.ctrlKey || ev.metaKey || ev.altKey) return;
    const tag = ev.target && ev.target.tagName;
    if (tag === 'SELECT' && (ev.key === 'ArrowUp' || ev.key === 'ArrowDown')) return;
    let handled = true;
    if (ev.key === ' ') setPlaying(!state.playing);
    else if (ev.key === 'ArrowLeft') step(-1);
    else if (ev.key === 'ArrowRight') step(1);
    else if (ev.key === 'Home') { setPlaying(false); seekFrame(0); }
    else if (ev.key === 'End') { setPlaying(false); seekFrame(F - 1); }
    else if (ev.key === 'r' || ev.key === 'R') { view.resetView(); state.dirty = true; }
    else handled = false;
    if (handled) {
      ev.preventDefault();
      if (ev.target && ev.target.blur && tag !== 'BODY') ev.target.blur();
    }
  });

  // Re-render at once on resize (headless screenshots resize just before capture).
  window.addEventListener('resize', () => {
    view.resize();
    curves.resize();
    renderNow(performance.now());
  });

  // --- initial state from the hash --------------------------------------------
  function applyOptions(o) {
    if (o.follow != null) {
      const i = desc.bodies.findIndex((b) => b.name === o.follow);
      followSel.value = i >= 0 ? String(i) : '';
      view.setFollow(i >= 0 ? i : null);
    }
    if (o.trails) {
      for (const name of o.trails) {
        const i = desc.bodies.findIndex((b) => b.name === name);
        if (i >= 0) { trailBoxes[i].checked = true; view.setTrail(i, true); }
      }
    }
    if (o.axes != null) { axesBox.checked = o.axes; view.setAxes(o.axes); }
    if (o.field && view.hasMeshes && ['vm', 'disp', 'none'].includes(o.field)) {
      fieldSel.value = o.field;
      view.setField(o.field);
    }
    if (o.beamfield && view.hasBeamSections && ['axial', 'bending', 'torsion', 'none'].includes(o.beamfield)) {
      beamSel.value = o.beamfield;
      view.setBeamField(o.beamfield);
    }
    showColorBar(data, view.field);
    showBeamBar(data, view.beamField);
    if (o.t != null) {
      setPlaying(false);
      seekFrame(data.nearestFrame(o.t));
    } else {
      seekFrame(0);
      setPlaying(F > 1);
    }
  }
  applyOptions(opts);

  // --- rendering ------------------------------------------------------------------------
  function updateUi() {
    scrub.value = String(view.frame);
    const t = data.time(view.frame);
    timeLabel.textContent = F > 0
      ? `t = ${t.toFixed(decimals)} s / ${tEnd.toFixed(decimals)} s   frame ${view.frame + 1}/${F}`
      : 'no frames';
    curves.draw(t);
  }

  const pulsing = view.hasHighlight;
  function renderNow(now) {
    if (pulsing) view.pulse(now / 1000);
    view.render();
    updateUi();
    state.dirty = false;
    afterRender(state.playing);
  }

  let last = null;
  function loop(now) {
    const dt = last == null ? 0 : Math.min(0.25, (now - last) / 1000);
    last = now;
    if (state.playing) {
      if (state.speed === 'frame') {
        showFrame(view.frame + 1);
      } else {
        state.simTime += dt * state.speed;
        const i = data.frameAtOrBefore(state.simTime);
        if (i !== view.frame) showFrame(i);
      }
      if (view.frame >= F - 1) setPlaying(false); // a failed run stops at its last frame
    }
    if (state.dirty || pulsing) renderNow(now);
    requestAnimationFrame(loop);
  }

  // First frame synchronously (so the test hooks are ready early), then the loop.
  renderNow(performance.now());
  requestAnimationFrame(loop);
  return {
    applyOptions,
    /** Seek to the frame nearest time t, keeping the play state. */
    seekTime(t) {
      seekFrame(data.nearestFrame(t));
    },
  };
}
