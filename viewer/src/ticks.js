// Tick labels of a plot's value axis, readable whatever the range (as matplotlib's
// ScalarFormatter does): when the range is tiny next to the values (a conservative run's
// energy, 1234.5678901 J give or take 1e-7), the ticks show their difference from an offset
// written once ("+1234.56789"); when the differences are themselves very small or very large,
// they are shown in units of a power of ten written once ("x1e-7"). Pure functions, no uPlot.

/** Offset when the ticks share this many leading digits or more (matplotlib's threshold). */
export const OFFSET_DIGITS = 4;
/** Labels in plain decimals for magnitudes in [1e-3, 1e5); a power of ten outside. */
export const SCALE_LIMITS = [-3, 5];

/** Decimals that write x (> 0) exactly at 1e-6 of it: 0.25 -> 2, 5 -> 0, 0.001 -> 3. */
export function decimalsFor(x) {
  if (!(x > 0) || !Number.isFinite(x)) return 0;
  for (let k = Math.max(0, -Math.floor(Math.log10(x))); k < 20; ++k) {
    const s = x * 10 ** k;
    if (Math.abs(s - Math.round(s)) <= 1e-6 * s) return k;
  }
  return 20;
}

/** Fixed-point text of x with k decimals, and no "-0". */
function fixed(x, k) {
  const t = x.toFixed(Math.min(k, 100));
  return /^-0(\.0*)?$/.test(t) ? t.slice(1) : t;
}

/** Text of the offset, signed, with the digits its rounding step p needs: "+1234.56789". */
export function offsetText(offset, p) {
  const sign = offset < 0 ? '-' : '+';
  const m = Math.abs(offset);
  if (m >= 1e-3 && m < 1e6) return sign + fixed(m, decimalsFor(p)).replace(/(\.\d*?)0+$/, '$1').replace(/\.$/, '');
  // Significant digits from the magnitude down to p.
  const digits = Math.min(Math.max(Math.floor(Math.log10(m)) - Math.floor(Math.log10(p)), 0), 16);
  return sign + m.toExponential(digits).replace(/\.?0+e/, 'e').replace('e+', 'e');
}

/**
 * Labels for ticks `values` spaced `step` apart (uPlot's splits and increment): { labels,
 * offset, scale, text }. offset is subtracted from every tick and scale (a power of ten)
 * divides the difference; `text` says both ("x1e-7 +1234.56789"), '' when neither is used, so
 * that a tick's value is scale x label + offset. Ordinary ranges get no offset and no scale:
 * their labels are the tick values with the decimals the step needs.
 */
export function tickLabels(values, step) {
  const finite = values.filter((v) => v != null && Number.isFinite(v));
  if (!finite.length) return { labels: values.map(() => ''), offset: 0, scale: 1, text: '' };
  const lo = Math.min(...finite);
  const hi = Math.max(...finite);
  const range = hi - lo;
  let spacing = step > 0 && Number.isFinite(step) ? step : range;
  if (!(spacing > 0)) spacing = Math.abs(lo) || 1; // one tick, or a constant series
  // The offset: the ticks' common leading digits, when they share OFFSET_DIGITS or more, as
  // a multiple of p = 10^ceil(log10(range)) so that each tick differs from it by less than 2p.
  let offset = 0;
  let p = 0;
  const size = Math.max(Math.abs(lo), Math.abs(hi));
  if (range > 0 && size / range >= 10 ** OFFSET_DIGITS) {
    p = 10 ** Math.ceil(Math.log10(range));
    offset = lo >= 0 ? Math.floor(lo / p) * p : Math.ceil(hi / p) * p;
  }
  // The scale: a power of ten when the largest difference from the offset is out of limits.
  const largest = Math.max(...finite.map((v) => Math.abs(v - offset)));
  let exponent = 0;
  if (largest > 0) {
    const oom = Math.floor(Math.log10(largest));
    if (oom < SCALE_LIMITS[0] || oom >= SCALE_LIMITS[1]) exponent = oom;
  }
  const scale = 10 ** exponent;
  const k = decimalsFor(spacing / scale);
  const labels = values.map((v) => (v == null || !Number.isFinite(v) ? '' : fixed((v - offset) / scale, k)));
  const parts = [];
  if (exponent !== 0) parts.push(`\u00d71e${exponent}`);
  if (offset !== 0) parts.push(offsetText(offset, p));
  return { labels, offset, scale, text: parts.join(' ') };
}
