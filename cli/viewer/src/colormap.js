// Colour maps: the sequential one for magnitudes (a "jet"-like blue -> cyan ->
// green -> yellow -> red; mesh fields, beam bending |M|) and a diverging one for
// signed quantities (blue -> white -> red; beam N1 and M1, range +-max), and
// number formatting shared by the colour bars, the curves panel and the info line.

/** Sequential map: u in [0, 1]. */
export const STOPS = [
  [0.0, [0.13, 0.25, 0.85]],
  [0.25, [0.1, 0.75, 0.95]],
  [0.5, [0.2, 0.8, 0.3]],
  [0.75, [0.98, 0.85, 0.15]],
  [1.0, [0.9, 0.15, 0.1]],
];

/** Diverging map: u in [0, 1] for values -max..+max (0.5 is zero, white). */
export const DIVERGING = [
  [0.0, [0.16, 0.27, 0.72]],
  [0.25, [0.5, 0.64, 0.93]],
  [0.5, [0.97, 0.97, 0.97]],
  [0.75, [0.95, 0.6, 0.48]],
  [1.0, [0.72, 0.08, 0.12]],
];

/** Map u in [0,1] to sRGB in [0,1] by the stops (sequential by default), written into out[o..o+2]. */
export function colormap(u, out, o, stops = STOPS) {
  if (!(u > 0)) u = 0;
  if (u > 1) u = 1;
  let k = 1;
  while (k < stops.length - 1 && stops[k][0] < u) k++;
  const [u0, c0] = stops[k - 1];
  const [u1, c1] = stops[k];
  const f = (u - u0) / (u1 - u0);
  out[o] = c0[0] + f * (c1[0] - c0[0]);
  out[o + 1] = c0[1] + f * (c1[1] - c0[1]);
  out[o + 2] = c0[2] + f * (c1[2] - c0[2]);
}

/** CSS linear-gradient (bottom = 0, top = 1) matching colormap() with these stops. */
export function cssGradient(stops = STOPS) {
  const parts = stops.map(([u, c]) => `rgb(${c.map((x) => Math.round(x * 255)).join(',')}) ${u * 100}%`);
  return `linear-gradient(to top, ${parts.join(', ')})`;
}

const PREFIXES = [
  [1e9, 'G'], [1e6, 'M'], [1e3, 'k'], [1, ''], [1e-3, 'm'], [1e-6, 'µ'], [1e-9, 'n'],
];

/** Format a value with an SI prefix, e.g. 1.23e6 Pa -> "1.23 MPa". */
export function formatSI(v, unit) {
  if (!isFinite(v)) return `${v} ${unit}`;
  const a = Math.abs(v);
  if (a === 0) return `0 ${unit}`;
  for (const [s, p] of PREFIXES) {
    if (a >= s * 0.9995) return `${(v / s).toPrecision(3)} ${p}${unit}`;
  }
  return `${v.toExponential(2)} ${unit}`;
}

/** Compact number formatting for axes and legends. */
export function formatNum(v) {
  if (!isFinite(v)) return String(v);
  const a = Math.abs(v);
  if (a !== 0 && (a >= 1e5 || a < 1e-3)) return v.toExponential(2);
  return String(Number(v.toPrecision(4)));
}
