// The configuration at a time: interpolated mass centres, O_K and Q_K from the model.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { createMotion } from '../../src/motion.js';
import { decodeTrajectory } from '../../src/data.js';
import { step, neighbourRow } from '../../src/playback.js';
import { fitView, upDirection } from '../../src/fit.js';

const close = (a, b, tol, what) => assert.ok(Math.abs(a - b) <= tol, `${what}: ${a} vs ${b} (tol ${tol})`);
const axisAngle = (n, a) => [...n.map((c) => Math.sin(a / 2) * c), Math.cos(a / 2)];

/** A page's data as kanedyn view writes it, from rows of numbers in the CSV's columns. */
function pageData(model, rows) {
  const columns = ['t'];
  for (const b of model.bodies) {
    for (const s of ['x', 'y', 'z', 'e1', 'e2', 'e3', 'e4', 's1', 's2', 's3', 'w1', 'w2', 'w3', 'sd1', 'sd2', 'sd3']) {
      columns.push(`${b.name}.${s}`);
    }
  }
  columns.push('energy');
  const f64c = [];
  const f32c = [];
  columns.forEach((c, i) => ((i === 0 || /\.[xyz]$/.test(c)) ? f64c : f32c).push(i));
  const f64 = new Float64Array(f64c.length * rows.length);
  const f32 = new Float32Array(f32c.length * rows.length);
  f64c.forEach((c, j) => rows.forEach((r, i) => { f64[j * rows.length + i] = r[c]; }));
  f32c.forEach((c, j) => rows.forEach((r, i) => { f32[j * rows.length + i] = r[c]; }));
  const b64 = (a) => Buffer.from(a.buffer).toString('base64');
  return { model, columns, rows: rows.length, rows_in_file: rows.length, stride: 1, f64_columns: f64c, f32_columns: f32c, f64: b64(f64), f32: b64(f32) };
}

// Two bodies: a pendulum rod (O_1 at the origin) and a second rod hanging from its tip.
const model = {
  gravity: [0, 0, -9.81],
  bodies: [
    { name: 'a', L: -1, mass: 1, com: [0, 0, -0.5], joint: [0, 0, 0], semi_axes: [0.1, 0.1, 0.5], principal: [0, 0, 0, 1] },
    { name: 'b', L: 0, mass: 1, com: [0, 0, -0.5], joint: [0, 0, -1], semi_axes: [0.1, 0.1, 0.5], principal: [0, 0, 0, 1] },
  ],
};
/** A row: both rods turned by angle th about y, b hinged at a's tip with no translation. */
function row(t, th) {
  const e = axisAngle([0, 1, 0], th);
  const r = [t];
  // a: O at the origin, G at R^T (0, 0, -0.5) = (-0.5 sin th, 0, -0.5 cos th).
  r.push(-0.5 * Math.sin(th), 0, -0.5 * Math.cos(th), ...e, 0, 0, 0, 0, 0, 0, 0, 0, 0);
  r.push(-1.5 * Math.sin(th), 0, -1.5 * Math.cos(th), ...e, 0, 0, 0, 0, 0, 0, 0, 0, 0);
  r.push(-9.81 * 2 * Math.cos(th));
  return r;
}

test('decodeTrajectory gives the columns back, f64 exactly and f32 to float32', () => {
  const d = pageData(model, [row(0, 0.1), row(0.5, 0.3)]);
  const traj = decodeTrajectory(d);
  assert.equal(traj.rows, 2);
  assert.equal(traj.column('a.x')[1], -0.5 * Math.sin(0.3));
  assert.equal(traj.column('b.e2')[0], Math.fround(Math.sin(0.05)));
  assert.equal(traj.index('energy'), 2 + 32 - 1);
  assert.throws(() => decodeTrajectory({ ...d, rows: 3 }), /damaged/);
});

test('between rows: G linear, eps slerped, O and Q from the model', () => {
  const traj = decodeTrajectory(pageData(model, [row(0, 0.2), row(1, 0.6)]));
  const motion = createMotion(model, traj);
  assert.equal(motion.start, 0);
  assert.equal(motion.end, 1);
  const f = motion.at(0.25);
  // G: a quarter of the way from one row's value to the next (linear, not along the arc).
  close(f[0].g[0], -0.5 * (0.75 * Math.sin(0.2) + 0.25 * Math.sin(0.6)), 1e-15, 'G_a.x');
  // eps: a quarter of the way along the arc, th = 0.3. float32 storage: 6e-8 relative.
  const e = axisAngle([0, 1, 0], 0.3);
  for (let k = 0; k < 4; ++k) close(f[0].e[k], e[k], 1e-7, `eps_a ${k + 1}`);
  // O_a = G_a - R^T r' and Q_b = O_a + R_a^T q'_b, the tip of a at th = 0.3 ... up to the
  // chord-vs-arc difference of G, which moves O with it: G lerped is not on the arc.
  const ga = f[0].g;
  const c = Math.cos(0.3);
  const s = Math.sin(0.3);
  close(f[0].o[0], ga[0] + 0.5 * s, 1e-7, 'O_a.x');
  close(f[0].o[2], ga[2] + 0.5 * c, 1e-7, 'O_a.z');
  close(f[1].q[0], f[0].o[0] - s, 1e-7, 'Q_b.x');
  close(f[1].q[2], f[0].o[2] - c, 1e-7, 'Q_b.z');
  // A root's Q is its joint point in inertial components.
  assert.deepEqual(f[0].q, [0, 0, 0]);
  // At a row's time, the row exactly.
  const g = motion.at(1);
  assert.equal(g[1].g[0], -1.5 * Math.sin(0.6));
});

test('playback steps at speed, loops or stops', () => {
  assert.deepEqual(step(1, 0.1, 2, 0, 10, true), { t: 1.2, playing: true });
  assert.deepEqual(step(9.9, 0.1, 5, 0, 10, false), { t: 10, playing: false });
  const r = step(9.9, 0.1, 5, 0, 10, true);
  assert.equal(r.playing, true);
  close(r.t, 0.4, 1e-12, 'looped t');
});

test('the arrow keys step to the neighbouring rows', () => {
  const times = [0, 0.1, 0.2, 0.3];
  assert.equal(neighbourRow(times, 0, 1), 0.1);
  assert.equal(neighbourRow(times, 0.1, 1), 0.2);
  assert.equal(neighbourRow(times, 0.15, 1), 0.2);
  assert.equal(neighbourRow(times, 0.3, 1), 0.3);
  assert.equal(neighbourRow(times, 0.15, -1), 0.1);
  assert.equal(neighbourRow(times, 0.1, -1), 0);
  assert.equal(neighbourRow(times, 0, -1), 0);
  assert.equal(neighbourRow(times, 0.3, -1), 0.2);
});

test('the view fits a 0.1 m gadget and a 100 m chain alike', () => {
  for (const scale of [0.05, 1, 100]) {
    const m = {
      gravity: [0, 0, -9.81],
      bodies: model.bodies.map((b) => ({
        ...b, com: b.com.map((c) => c * scale), joint: b.joint.map((c) => c * scale), semi_axes: b.semi_axes.map((c) => c * scale),
      })),
    };
    const rows = [row(0, 0.2), row(1, 0.6)].map((r) => r.map((v, i) => ((i - 1) % 16 < 3 && i > 0 && i < 33 ? v * scale : v)));
    const fit = fitView(m, createMotion(m, decodeTrajectory(pageData(m, rows))));
    // The model spans about 1.5 scale; the radius must be of that order, not a fixed size.
    assert.ok(fit.radius > 0.5 * scale && fit.radius < 3 * scale, `scale ${scale}: radius ${fit.radius}`);
    assert.ok(fit.gridSize >= 2 * fit.radius && fit.gridSize < 60 * fit.radius, `grid ${fit.gridSize}`);
  }
  assert.deepEqual(upDirection([0, -9.81, 0]).map((c) => c + 0), [0, 1, 0]);
  assert.deepEqual(upDirection([0, 0, 0]), [0, 0, 1]);
});
