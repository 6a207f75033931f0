// Test hooks for the headless-Chromium test on the Rust side (no interaction):
//  * errors: window.onerror, unhandledrejection and console.error are captured
//    from the moment this module is evaluated (it is imported first);
//  * the URL hash `#t=1.25&follow=rod1&trails=rod1,rod2&axes=1&field=vm&beamfield=axial&speed=2&size=1000x700`
//    is parsed by parseHash() (size pins the page layout to W x H CSS px, so that
//    a --dump-dom run and a --screenshot run lay out identically: headless
//    Chromium gives the page a shorter viewport for --dump-dom than for --screenshot);
//  * after each render, writeTestState() fills <pre id="mbdc-test"> with
//    {"ready":true,"frame":k,"t":t,"errors":[...],"width":W,"height":H,"bodies":[...],"beam_field":f}
//    and sets document.body.dataset.status = "ready".

/** Captured error messages (strings). */
export const errors = [];

function describe(x) {
  if (x instanceof Error) return `${x.name}: ${x.message}`;
  if (typeof x === 'string') return x;
  try {
    return JSON.stringify(x);
  } catch (_) {
    return String(x);
  }
}

window.addEventListener('error', (ev) => {
  const where = ev.filename ? ` (${ev.filename.split('/').pop()}:${ev.lineno}:${ev.colno})` : '';
  errors.push(`error: ${ev.error ? describe(ev.error) : ev.message}${where}`);
});
window.addEventListener('unhandledrejection', (ev) => {
  errors.push(`unhandledrejection: ${describe(ev.reason)}`);
});
const consoleError = console.error.bind(console);
console.error = (...args) => {
  errors.push(`console.error: ${args.map(describe).join(' ')}`);
  consoleError(...args);
};

/** Parse the URL hash into {t, follow, trails, axes, field, beamfield, speed, size} (missing keys absent). */
export function parseHash(hash) {
  const out = {};
  const h = (hash || '').replace(/^#/, '');
  if (!h) return out;
  for (const part of h.split('&')) {
    const eq = part.indexOf('=');
    const k = decodeURIComponent(eq < 0 ? part : part.slice(0, eq));
    const v = eq < 0 ? '' : decodeURIComponent(part.slice(eq + 1));
    if (k === 't') {
      const t = Number(v);
      if (v !== '' && isFinite(t)) out.t = t;
    } else if (k === 'follow') out.follow = v;
    else if (k === 'trails') out.trails = v.split(',').filter(Boolean);
    else if (k === 'axes') out.axes = v !== '0' && v !== 'false';
    else if (k === 'field') out.field = v;
    else if (k === 'beamfield') out.beamfield = v;
    else if (k === 'speed') out.speed = v;
    else if (k === 'size') {
      const m = /^(\d+)x(\d+)$/.exec(v);
      if (m) out.size = [Number(m[1]), Number(m[2])];
    }
  }
  return out;
}

let pre = null;

/** Write the test JSON for the frame just rendered. */
export function writeTestState(view, data) {
  if (!pre) {
    pre = document.getElementById('mbdc-test');
    if (!pre) {
      pre = document.createElement('pre');
      pre.id = 'mbdc-test';
      pre.style.display = 'none';
      document.body.appendChild(pre);
    }
  }
  const state = {
    ready: true,
    frame: view ? view.frame : 0,
    t: data ? data.time(view ? view.frame : 0) : 0,
    errors: errors.slice(),
    width: window.innerWidth,
    height: window.innerHeight,
    bodies: view ? view.projectBodies() : [],
    beam_field: view ? view.beamField : 'none',
  };
  pre.textContent = JSON.stringify(state);
  document.body.dataset.status = 'ready';
}

/** Report a fatal start-up failure (still "ready", so the test sees the errors). */
export function writeFatal(err) {
  errors.push(`fatal: ${describe(err)}`);
  writeTestState(null, null);
}
