// Between two rows: positions linearly, orientations by slerp of the Euler parameters.

/**
 * The interval of a sorted time array that holds t: { i, u } with times[i] <= t <= times[i+1]
 * and u in [0, 1] the fraction of the way; clamped to the ends. Binary search: O(log n).
 */
export function locate(times, t) {
  const n = times.length;
  if (n === 0) throw new Error('no rows');
  if (n === 1 || t <= times[0]) return { i: 0, u: 0 };
  if (t >= times[n - 1]) return { i: n - 2, u: 1 };
  let lo = 0;
  let hi = n - 1; // times[lo] <= t < times[hi]
  while (hi - lo > 1) {
    const mid = (lo + hi) >> 1;
    if (times[mid] <= t) lo = mid;
    else hi = mid;
  }
  const span = times[hi] - times[lo];
  return { i: lo, u: span > 0 ? (t - times[lo]) / span : 0 };
}

/** a + u (b - a). */
export function lerp(a, b, u) {
  return a + u * (b - a);
}

/**
 * Slerp between unit Euler parameters p and q (arrays [e1, e2, e3, e4], e4 scalar): the
 * rotation a fraction u of the way along the shorter arc. q and -q are the same rotation, so
 * q is flipped when p.q < 0. Near-equal parameters fall back to normalized linear
 * interpolation (sin(theta) -> 0 loses precision; the two agree to O(theta^3)).
 */
export function slerp(p, q, u, out = [0, 0, 0, 0]) {
  let dot = p[0] * q[0] + p[1] * q[1] + p[2] * q[2] + p[3] * q[3];
  let s = 1;
  if (dot < 0) {
    dot = -dot;
    s = -1;
  }
  let a;
  let b;
  if (dot > 0.9995) {
    a = 1 - u;
    b = u;
  } else {
    const theta = Math.acos(Math.min(dot, 1));
    const sin = Math.sin(theta);
    a = Math.sin((1 - u) * theta) / sin;
    b = Math.sin(u * theta) / sin;
  }
  b *= s;
  for (let k = 0; k < 4; ++k) out[k] = a * p[k] + b * q[k];
  const norm = Math.hypot(out[0], out[1], out[2], out[3]);
  for (let k = 0; k < 4; ++k) out[k] /= norm;
  return out;
}

/**
 * {v} in inertial components of a body-fixed vector with body components vb: R^T vb, where
 * [R] (Eqs. 3-4) maps inertial to body components:
 * R = [[e1²-e2²-e3²+e4², 2(e1e2+e3e4), 2(e1e3-e2e4)],
 *      [2(e1e2-e3e4), -e1²+e2²-e3²+e4², 2(e2e3+e1e4)],
 *      [2(e1e3+e2e4), 2(e2e3-e1e4), -e1²-e2²+e3²+e4²]].
 */
export function bodyToInertial(e, vb, out = [0, 0, 0]) {
  const r = rotationMatrix(e);
  const [x, y, z] = vb;
  out[0] = r[0] * x + r[3] * y + r[6] * z;
  out[1] = r[1] * x + r[4] * y + r[7] * z;
  out[2] = r[2] * x + r[5] * y + r[8] * z;
  return out;
}

/** [R] of Eqs. (3)-(4), row-major (9 numbers): inertial -> body components. */
export function rotationMatrix(e) {
  const [e1, e2, e3, e4] = e;
  const e11 = e1 * e1; const e22 = e2 * e2; const e33 = e3 * e3; const e44 = e4 * e4;
  return [
    e11 - e22 - e33 + e44, 2 * (e1 * e2 + e3 * e4), 2 * (e1 * e3 - e2 * e4),
    2 * (e1 * e2 - e3 * e4), -e11 + e22 - e33 + e44, 2 * (e2 * e3 + e1 * e4),
    2 * (e1 * e3 + e2 * e4), 2 * (e2 * e3 - e1 * e4), -e11 - e22 + e33 + e44,
  ];
}
