// Entry point of the `mbdc view` page: decode the data, build the scene,
// the curves panel and the controls, and start playback.
//
// testhooks.js is imported first so that error capture is in place before
// anything else runs.

import { errors, parseHash, writeFatal, writeTestState } from './testhooks.js';
import { loadData } from './data.js';
import { createScene } from './scene.js';
import { createCurves } from './curves.js';
import { showInfo } from './overlay.js';
import { startPlayback } from './playback.js';

function main() {
  const opts = parseHash(location.hash);
  // Pin the layout (test hook) so that it no longer follows the window size: to
  // `size=WxH` from the hash, or, in headless Chromium, to the viewport at load.
  // (Headless Chromium lays a page out in a shorter viewport than --window-size
  // and, for --screenshot, resizes it just before the capture; pinned, a
  // --dump-dom run and a --screenshot run put every body at the same pixel.)
  const pin = opts.size || (/HeadlessChrome/.test(navigator.userAgent) ? [window.innerWidth, window.innerHeight] : null);
  if (pin) {
    document.body.style.width = `${pin[0]}px`;
    document.body.style.height = `${pin[1]}px`;
  }
  const data = loadData();
  showInfo(data);
  const view = createScene(document.getElementById('view'), data);

  let playback = null;
  const curves = createCurves(document.getElementById('curves'), data, (t) => {
    // Seek to the frame nearest the clicked time (keeps playing if it was).
    if (playback) playback.seekTime(t);
  });

  // Test JSON after every render (cheap: a projection per drawn body), so it always
  // describes the frame on screen; while playing with many bodies, at most 4 times a second.
  let lastWrite = -Infinity;
  const afterRender = (playing) => {
    const now = performance.now();
    if (!playing || data.slots < 200 || now - lastWrite > 250) {
      lastWrite = now;
      writeTestState(view, data);
    }
  };

  playback = startPlayback(view, data, curves, opts, afterRender);
  window.addEventListener('hashchange', () => playback.applyOptions(parseHash(location.hash)));

  // Debug handle for the browser console.
  window.mbdcView = { data, view, errors };
}

try {
  main();
} catch (err) {
  writeFatal(err); // recorded in the test JSON
  console.log(err);
  const info = document.getElementById('info');
  if (info) info.textContent = `viewer failed to start: ${err && err.message ? err.message : err}`;
}
