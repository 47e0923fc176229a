// Path traces, the model's frames, the grid's plane, the follow camera's radius and a mode
// page's plotted coordinates: the pure parts (src/traces.js, src/fit.js, src/modeplot.js).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { framePose, pointAt, tracePath, tracePoints, tracedSegments } from '../../src/traces.js';
import { followRadius, groundLevel } from '../../src/fit.js';
import { modePlotColumns } from '../../src/modeplot.js';

const close = (a, b, tol, what) => assert.ok(Math.abs(a - b) <= tol, `${what}: ${a} vs ${b} (tol ${tol})`);
const closeVec = (a, b, tol, what) => a.forEach((x, i) => close(x, b[i], tol, `${what}[${i}]`));
const axisAngle = (n, a) => [...n.map((c) => Math.sin(a / 2) * c), Math.cos(a / 2)];

// One body, its mass centre moving along (t, 2t, 0) while it turns about z at 1 rad/s; its
// origin O is G (com zero). A frame on it at (1, 0, 0) turned 90 degrees about x, and one on
// the ground.
const model = {
  gravity: [0, 0, -9.81],
  bodies: [{ name: 'cart', L: -1, com: [0, 0, 0], joint: [0, 0, 0], semi_axes: [0.1, 0.2, 0.3] }],
  frames: [
    { name: 'tool', body: 0, at: [1, 0, 0], rotation: axisAngle([1, 0, 0], Math.PI / 2) },
    { name: 'mark', body: -1, at: [5, 6, 7], rotation: [0, 0, 0, 1] },
  ],
};
const motion = {
  times: [0, 0.5, 1, 1.5, 2],
  at: (t) => [{ g: [t, 2 * t, 0], o: [t, 2 * t, 0], q: [0, 0, 0], e: axisAngle([0, 0, 1], t) }],
};

test('the traceable points: every mass centre, then every frame', () => {
  assert.deepEqual(tracePoints(model).map((p) => `${p.kind} ${p.name} ${p.index}`), ['body cart 0', 'frame tool 0', 'frame mark 1']);
  assert.deepEqual(tracePoints({ bodies: model.bodies }).length, 1);
});

test('a frame\'s origin and axes by hand', () => {
  const t = Math.PI / 2; // the body turned 90 degrees about z: its x is inertial y
  const frame = motion.at(t);
  const { origin, axes } = framePose(model, 0, frame);
  // O + R^T at: (t, 2t, 0) + (0, 1, 0). Round-off only.
  closeVec(origin, [t, 2 * t + 1, 0], 1e-12, 'origin');
  closeVec(pointAt(model, tracePoints(model)[1], frame), origin, 0, 'the traced point is the origin');
  // The frame's axes are the body's turned 90 degrees about its x: x_f = x_b = inertial y,
  // y_f = z_b = inertial z, z_f = -y_b = inertial x.
  closeVec(axes[0], [0, 1, 0], 1e-12, 'x');
  closeVec(axes[1], [0, 0, 1], 1e-12, 'y');
  closeVec(axes[2], [1, 0, 0], 1e-12, 'z');
  // A ground frame is inertial.
  const ground = framePose(model, 1, frame);
  closeVec(ground.origin, [5, 6, 7], 0, 'ground origin');
  closeVec(ground.axes[2], [0, 0, 1], 0, 'ground z');
});

test('a path at the rows, every stride-th row and the last when there are many', () => {
  const p = tracePoints(model)[0];
  const all = tracePath(model, motion, p);
  assert.deepEqual([...all.times], motion.times);
  motion.times.forEach((t, i) => closeVec(all.points.subarray(3 * i, 3 * i + 3), [t, 2 * t, 0], 0, `row ${i}`));
  const some = tracePath(model, motion, p, 2); // 5 rows, at most about 2: rows 0, 3 and the last
  assert.deepEqual([...some.times], [0, 1.5, 2]);
});

test('the segments up to a time: whole ones, and a partial one to the point', () => {
  const times = [0, 1, 2, 3];
  // A linear scan: the segments whose end is at or before t, and a partial one when t is
  // strictly inside the next.
  for (const t of [-1, 0, 0.25, 1, 1.5, 2, 2.999, 3, 4]) {
    let whole = 0;
    while (whole + 1 < times.length && times[whole + 1] <= t) ++whole;
    const partial = whole + 1 < times.length && t > times[whole];
    assert.deepEqual(tracedSegments(times, t), { whole, partial }, `t = ${t}`);
  }
  assert.deepEqual(tracedSegments([0], 5), { whole: 0, partial: false });
});

test('the grid: the ground plane through the origin under gravity, below the motion without', () => {
  const lo = [-1, -1, -3];
  const hi = [1, 1, -2];
  // A chain hanging below its pivot: the floor is still the plane through the origin.
  assert.equal(groundLevel(model, [0, 0, 1], lo, hi), 0);
  // Up along -y (gravity along +y): the plane through the origin normal to it.
  assert.equal(groundLevel({ ...model, gravity: [0, 9.81, 0] }, [0, -1, 0], lo, hi), 0);
  // No gravity: no floor; below the box along up (+z): z = -3.
  assert.equal(groundLevel({ ...model, gravity: [0, 0, 0] }, [0, 0, 1], lo, hi), -3);
  // Wheels on the plane z = 0.5 normal to up: that plane.
  const wheels = {
    ...model,
    constraints: [{ type: 'rolling_disc', body: 0, at: [0, 0, 0], axis: [0, 1, 0], radius: 0.3, plane_normal: [0, 0, 1], plane_offset: 0.5 }],
  };
  assert.equal(groundLevel(wheels, [0, 0, 1], lo, hi), 0.5);
});

test('the follow camera\'s radius: the configuration now about the followed mass centre', () => {
  // Two bodies 3 m apart, the second on the first (its Q counts), the root's Q at the origin
  // far behind (it does not): the farthest from G_1 is b's ellipsoid, 3 m on and its largest
  // semi-axis 0.5 beyond; from G_2, a's, 3 m and 0.3.
  const m = {
    bodies: [
      { name: 'a', L: -1, semi_axes: [0.1, 0.2, 0.3] },
      { name: 'b', L: 0, semi_axes: [0.5, 0.1, 0.1] },
    ],
  };
  const frame = [
    { g: [100, 0, 0], o: [100, 0, 0], q: [0, 0, 0] },
    { g: [103, 0, 0], o: [102, 0, 0], q: [101, 0, 0] },
  ];
  close(followRadius(m, frame, 0), 3.5, 1e-12, 'about a');
  close(followRadius(m, frame, 1), 3.3, 1e-12, 'about b');
});

test('a mode page plots the coordinates that move, largest swing first', () => {
  const cols = {
    'mode.a.r1': [0, 0.1, -0.1], // swing 0.2
    'mode.a.r2': [0, 0.004, -0.004], // 0.008: 4% of the largest, left out
    'mode.b.j1': [0.5, -0.5, 0], // 1.0
    'mode.c.s1': [0, 0.03, 0.02], // 0.03
  };
  const traj = { column: (n) => cols[n] };
  assert.deepEqual(modePlotColumns(traj, Object.keys(cols)), ['mode.b.j1', 'mode.a.r1']);
  assert.deepEqual(modePlotColumns(traj, Object.keys(cols), 8, 0.01), ['mode.b.j1', 'mode.a.r1', 'mode.c.s1']);
  assert.deepEqual(modePlotColumns(traj, Object.keys(cols), 1, 0), ['mode.b.j1']);
  // Nothing moves: the first ones, at most max.
  const still = { column: () => [0, 0] };
  assert.deepEqual(modePlotColumns(still, ['x', 'y', 'z'], 2), ['x', 'y']);
});
