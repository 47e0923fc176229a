// The constraints as drawn (src/constraints.js): a rolling disc's contact point against the
// lowest point of its rim found by sampling, loop closures' points and axes from the poses,
// and the ground plane the wheels roll on.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  closurePoints, closures, discContact, discGround, hasConstraints, pointOf, rollingDiscs,
} from '../../src/constraints.js';
import { bodyToInertial } from '../../src/interp.js';

const close = (a, b, tol, what) => assert.ok(Math.abs(a - b) <= tol, `${what}: ${a} vs ${b} (tol ${tol})`);
const closeVec = (a, b, tol, what) => a.forEach((c, i) => close(c, b[i], tol, `${what}[${i}]`));
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (u, v) => [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
const unit = (v) => v.map((c) => c / Math.hypot(...v));
/** Euler parameters (e1, e2, e3, e4) of a turn by angle a about the unit vector n. */
const axisAngle = (n, a) => [...n.map((c) => Math.sin(a / 2) * c), Math.cos(a / 2)];

const disc = (body, at, axis, radius, normal = [0, 0, 1], offset = 0) => ({
  name: `disc${body}`, type: 'rolling_disc', body, at, axis, radius, plane_normal: normal, plane_offset: offset,
});

test('which constraints are discs and which closures', () => {
  const model = {
    constraints: [
      disc(0, [0, 0, 0], [0, 1, 0], 0.3),
      { name: 'pin', type: 'ball', body: 1, at: [0, 0, 0], other: -1, other_at: [0, 0, 0] },
      disc(1, [0, 0, 0], [0, 1, 0], 0.35),
      { name: 'rod', type: 'distance', body: 1, at: [0, 0, 0], other: 0, other_at: [0, 0, 0], length: 1 },
    ],
  };
  assert.equal(hasConstraints(model), true);
  assert.equal(hasConstraints({ bodies: [] }), false);
  assert.deepEqual(rollingDiscs(model).map((c) => c.index), [0, 2]);
  assert.deepEqual(closures(model).map((c) => [c.name, c.index]), [['pin', 1], ['rod', 3]]);
});

test('a leaning wheel touches the ground at its rim\'s lowest point', () => {
  // A wheel of radius 0.3 with its axle along body y, leaning by roll phi about x: the lowest
  // rim point is C + r (0, sin phi, -cos phi), by hand.
  const r = 0.3;
  const phi = 0.4;
  const frame = [{ e: axisAngle([1, 0, 0], phi), o: [2, -1, r * Math.cos(phi)] }];
  const c = disc(0, [0, 0, 0], [0, 1, 0], r);
  const p = discContact(c, frame);
  closeVec(p.axis, [0, Math.cos(phi), Math.sin(phi)], 1e-15, 'axle');
  closeVec(p.d, [0, Math.sin(phi), -Math.cos(phi)], 1e-15, 'd');
  // On the ground z = 0: the centre's height is r cos(phi). Round-off only.
  closeVec(p.contact, [2, -1 + r * Math.sin(phi), 0], 1e-15, 'contact');
});

test('at any pose, the contact is the rim point lowest along the plane normal', () => {
  // Poses turned about several axes, an off-centre disc, tilted planes: the sampled rim's
  // lowest point along n, over 20000 angles, is within r (2 pi / 20000)^2 / 8 + round-off of
  // the computed one along n (the sampling's error in height), and within r 2 pi / 20000
  // (its error along the rim) in position.
  const cases = [
    { e: axisAngle(unit([1, 2, 3]), 0.7), at: [0.1, 0.2, -0.05], axis: [0, 1, 0], n: [0, 0, 1], off: 0 },
    { e: axisAngle(unit([-2, 0.5, 1]), 2.1), at: [0, 0, 0], axis: unit([0.3, 1, 0.2]), n: unit([0.1, -0.2, 1]), off: 0.4 },
    { e: axisAngle([0, 0, 1], 1.0), at: [0, 0, 0.5], axis: [1, 0, 0], n: [0, 0, -1], off: 0 },
  ];
  const r = 0.35;
  const samples = 20000;
  for (const k of cases) {
    const frame = [{ e: k.e, o: [0.3, -0.7, 1.1] }];
    const c = disc(0, k.at, k.axis, r, k.n, k.off);
    const p = discContact(c, frame);
    close(Math.hypot(...p.d), 1, 1e-15, '|d|');
    close(dot(p.d, p.axis), 0, 1e-15, 'd . a');
    // The rim: C + r (cos t u + sin t v), u and v an orthonormal pair normal to the axle.
    const a = p.axis;
    const u = unit(cross(a, Math.abs(a[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0]));
    const v = cross(a, u);
    let best = null;
    for (let i = 0; i < samples; ++i) {
      const t = (2 * Math.PI * i) / samples;
      const q = p.centre.map((x, j) => x + r * (Math.cos(t) * u[j] + Math.sin(t) * v[j]));
      if (!best || dot(q, k.n) < dot(best, k.n)) best = q;
    }
    const dt = (2 * Math.PI) / samples;
    close(dot(p.contact, k.n), dot(best, k.n), (r * dt * dt) / 8 + 1e-14, 'height along n');
    closeVec(p.contact, best, r * dt, 'contact');
    // The centre is O_K + R^T at.
    const want = bodyToInertial(k.e, k.at).map((x, j) => x + frame[0].o[j]);
    closeVec(p.centre, want, 1e-15, 'centre');
  }
});

test('an axle along the plane normal has no contact point', () => {
  const frame = [{ e: [0, 0, 0, 1], o: [0, 0, 1] }];
  const p = discContact(disc(0, [0, 0, 0], [0, 0, 1], 0.3), frame);
  assert.equal(p.contact, null);
  assert.equal(p.d, null);
});

test('loop closures: the two points and a hinge\'s axes from the poses', () => {
  // Body 0 turned a quarter turn about z at (1, 2, 3); body 1 unturned at (0, 0, 1).
  const frame = [
    { e: axisAngle([0, 0, 1], Math.PI / 2), o: [1, 2, 3] },
    { e: [0, 0, 0, 1], o: [0, 0, 1] },
  ];
  const hinge = { type: 'hinge', body: 0, at: [1, 0, 0], axis: [1, 0, 0], other: 1, other_at: [0, 0.5, 0], other_axis: [0, 0, 1] };
  const p = closurePoints(hinge, frame);
  // x of body 0 is inertial y after the quarter turn: by hand.
  closeVec(p.from, [1, 3, 3], 1e-15, 'from');
  closeVec(p.to, [0, 0.5, 1], 1e-15, 'to');
  closeVec(p.axis, [0, 1, 0], 1e-15, 'axis');
  closeVec(p.otherAxis, [0, 0, 1], 1e-15, 'other axis');
  // The ground's point is inertial; a ball has no axes.
  const ball = closurePoints({ type: 'ball', body: 1, at: [0, 0, -1], other: -1, other_at: [4, 5, 6] }, frame);
  closeVec(ball.from, [0, 0, 0], 1e-15, 'ball from');
  closeVec(ball.to, [4, 5, 6], 0, 'ball to');
  assert.equal(ball.axis, undefined);
  closeVec(pointOf(frame, -1, [7, 8, 9]), [7, 8, 9], 0, 'ground point');
});

test('the wheels\' ground plane along up', () => {
  const up = [0, 0, 1];
  const withDiscs = (...cs) => ({ constraints: cs });
  assert.equal(discGround(withDiscs(disc(0, [0, 0, 0], [0, 1, 0], 0.3), disc(1, [0, 0, 0], [0, 1, 0], 0.35)), up), 0);
  assert.equal(discGround(withDiscs(disc(0, [0, 0, 0], [0, 1, 0], 0.3, [0, 0, 1], 0.5)), up), 0.5);
  // n . p = 0.5 with n = -z is the plane z = -0.5.
  assert.equal(discGround(withDiscs(disc(0, [0, 0, 0], [0, 1, 0], 0.3, [0, 0, -1], 0.5)), up), -0.5);
  // Tilted, or two planes, or no discs: no ground plane of the wheels.
  assert.equal(discGround(withDiscs(disc(0, [0, 0, 0], [0, 1, 0], 0.3, unit([0, 0.1, 1]), 0)), up), null);
  assert.equal(discGround(withDiscs(disc(0, [0, 0, 0], [0, 1, 0], 0.3), disc(1, [0, 0, 0], [0, 1, 0], 0.3, [0, 0, 1], 1)), up), null);
  assert.equal(discGround({ constraints: [] }, up), null);
  assert.equal(discGround({}, up), null);
});
