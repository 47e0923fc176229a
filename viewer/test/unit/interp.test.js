// Interpolation between rows and the slerp of Euler parameters.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { locate, lerp, slerp, rotationMatrix, bodyToInertial } from '../../src/interp.js';

// Round-off of a few operations on numbers of order 1.
const TIGHT = 1e-12;
const close = (a, b, tol, what) => assert.ok(Math.abs(a - b) <= tol, `${what}: ${a} vs ${b} (tol ${tol})`);

/** Euler parameters of a rotation by angle about a unit axis: (sin(a/2) n, cos(a/2)). */
const axisAngle = (n, a) => [...n.map((c) => Math.sin(a / 2) * c), Math.cos(a / 2)];

test('locate finds the interval and the fraction, clamped at the ends', () => {
  const times = [0, 0.5, 1, 2];
  assert.deepEqual(locate(times, 0), { i: 0, u: 0 });
  assert.deepEqual(locate(times, -1), { i: 0, u: 0 });
  assert.deepEqual(locate(times, 5), { i: 2, u: 1 });
  assert.deepEqual(locate(times, 2), { i: 2, u: 1 });
  assert.deepEqual(locate(times, 1), { i: 2, u: 0 });
  const r = locate(times, 1.25);
  assert.equal(r.i, 2);
  close(r.u, 0.25, TIGHT, 'u');
  assert.deepEqual(locate([3], 7), { i: 0, u: 0 });
  assert.throws(() => locate([], 0));
});

test('locate agrees with a linear scan on uneven times', () => {
  const times = [];
  for (let k = 0, t = 0; k < 500; ++k) times.push((t += 0.001 + ((k * 7919) % 13) * 1e-3));
  for (let s = 0; s < 2000; ++s) {
    const t = times[0] + ((times.at(-1) - times[0]) * s) / 1999;
    let i = 0;
    while (i + 2 < times.length && times[i + 1] <= t) ++i;
    const r = locate(times, t);
    assert.equal(r.i, i, `t = ${t}`);
    close(times[i] + r.u * (times[i + 1] - times[i]), t, 1e-12, 'reconstructed t');
  }
});

test('lerp', () => {
  assert.equal(lerp(2, 4, 0), 2);
  assert.equal(lerp(2, 4, 1), 4);
  assert.equal(lerp(2, 4, 0.25), 2.5);
});

test('slerp turns at a constant rate about the fixed axis', () => {
  const n = [0.48, -0.6, 0.64]; // unit
  const p = axisAngle(n, 0.3);
  const q = axisAngle(n, 1.7);
  for (const u of [0, 0.1, 0.5, 0.9, 1]) {
    const e = slerp(p, q, u);
    const want = axisAngle(n, 0.3 + u * 1.4);
    for (let k = 0; k < 4; ++k) close(e[k], want[k], TIGHT, `u = ${u}, e${k + 1}`);
  }
});

test('slerp takes the shorter arc: q and -q give the same rotations', () => {
  const n = [0, 0, 1];
  const p = axisAngle(n, 0.2);
  const q = axisAngle(n, 0.8).map((c) => -c);
  const e = slerp(p, q, 0.5);
  const want = axisAngle(n, 0.5);
  const sign = Math.sign(e[3]) * Math.sign(want[3]);
  for (let k = 0; k < 4; ++k) close(sign * e[k], want[k], TIGHT, `e${k + 1}`);
});

test('slerp of nearly equal parameters stays unit and between them', () => {
  const n = [1, 0, 0];
  const p = axisAngle(n, 1.0);
  const q = axisAngle(n, 1.0 + 1e-9);
  const e = slerp(p, q, 0.5);
  close(Math.hypot(...e), 1, TIGHT, '|eps|');
  const want = axisAngle(n, 1.0 + 0.5e-9);
  for (let k = 0; k < 4; ++k) close(e[k], want[k], TIGHT, `e${k + 1}`);
});

test('[R] of Eqs. (3)-(4) maps inertial to body components', () => {
  // 5 degrees about y: the pelvis of examples/eight_body.yaml, whose [R] kanedyn inspect
  // prints as [[0.99619, 0, -0.087156], [0, 1, 0], [0.087156, 0, 0.99619]].
  const R = rotationMatrix(axisAngle([0, 1, 0], (5 * Math.PI) / 180));
  const want = [0.9961946980917457, 0, -0.08715574274765818, 0, 1, 0, 0.08715574274765818, 0, 0.9961946980917457];
  for (let k = 0; k < 9; ++k) close(R[k], want[k], TIGHT, `R[${k}]`);
  // A body-fixed x axis turned 90 degrees about z points along inertial y.
  const v = bodyToInertial(axisAngle([0, 0, 1], Math.PI / 2), [1, 0, 0]);
  [0, 1, 0].forEach((c, k) => close(v[k], c, TIGHT, `v${k}`));
});
