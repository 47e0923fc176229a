// The joints as drawn: which lines and markers, and the inertial end points of each axis line
// from the body poses.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  axisDirection, axisHalfLength, hasJoints, jointLines, jointMarkers, lineSegments, normalTo, segmentCount,
} from '../../src/joints.js';
import { bodyToInertial } from '../../src/interp.js';

const close = (a, b, tol, what) => assert.ok(Math.abs(a - b) <= tol, `${what}: ${a} vs ${b} (tol ${tol})`);
const closeVec = (a, b, tol, what) => a.forEach((c, i) => close(c, b[i], tol, `${what}[${i}]`));
const axisAngle = (n, a) => [...n.map((c) => Math.sin(a / 2) * c), Math.cos(a / 2)];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
/** The quaternion product p q (x, y, z, w): turn by q, then by p. */
const mul = (p, q) => [
  p[3] * q[0] + p[0] * q[3] + p[1] * q[2] - p[2] * q[1],
  p[3] * q[1] - p[0] * q[2] + p[1] * q[3] + p[2] * q[0],
  p[3] * q[2] + p[0] * q[1] - p[1] * q[0] + p[2] * q[3],
  p[3] * q[3] - p[0] * q[0] - p[1] * q[1] - p[2] * q[2],
];

const body = (name, L, joint_type, joint_axes) => ({
  name, L, mass: 1, com: [0, 0, 0], joint: [0, 0, 0], semi_axes: [0.1, 0.1, 0.5], principal: [0, 0, 0, 1], joint_type, joint_axes,
});
// A cart on a rail along x, a universal joint on it, a revolute link and a ball-jointed tip.
const model = {
  gravity: [0, 0, -9.81],
  bodies: [
    body('cart', -1, 'prismatic', [{ axis: [1, 0, 0], in: 'parent', turn: false, slide: true }]),
    body('yoke', 0, 'universal', [
      { axis: [0, 1, 0], in: 'parent', turn: true, slide: false },
      { axis: [1, 0, 0], in: 'body', turn: true, slide: false },
    ]),
    body('link', 1, 'revolute', [{ axis: [0, 0, 1], in: 'parent', turn: true, slide: false }]),
    body('tip', 2, 'spherical', []),
    body('plate', 2, 'weld', []),
    body('drum', 0, 'cylindrical', [{ axis: [0, 0, 1], in: 'parent', turn: true, slide: true }]),
    body('nut', 0, 'screw', [{ axis: [0, 0, 1], in: 'parent', turn: true, slide: true }]),
  ],
};
// Poses: each body turned about its own axis by its own angle, Q_K somewhere of its own.
const frame = [
  { e: axisAngle([0, 0, 1], 0.3), q: [0.5, 0, 0] },
  { e: axisAngle([0, 1, 0], -0.7), q: [0.5, 0.1, 0.2] },
  { e: axisAngle([1, 0, 0], 1.1), q: [0.6, -0.2, 0.3] },
  { e: axisAngle([0.6, 0.8, 0], 0.4), q: [1, 2, 3] },
  { e: axisAngle([0, 0, 1], 2.0), q: [-1, 0, 1] },
  { e: axisAngle([1, 0, 0], 0.2), q: [0, 0, 4] },
  { e: axisAngle([0, 0, 1], 0.5), q: [0, 0, 2] },
].map((f) => ({ ...f, g: [0, 0, 0], o: f.q }));

test('a model is jointed when its bodies have a joint type', () => {
  assert.equal(hasJoints(model), true);
  assert.equal(hasJoints({ bodies: [{ name: 'a', L: -1 }] }), false);
});

test('one line per axis, turning or sliding as the page says; markers for ball and weld', () => {
  const lines = jointLines(model);
  assert.deepEqual(lines.map((l) => [l.name, l.in, l.turn, l.slide]), [
    ['cart', 'parent', false, true],
    ['yoke', 'parent', true, false],
    ['yoke', 'body', true, false],
    ['link', 'parent', true, false],
    ['drum', 'parent', true, true],
    ['nut', 'parent', true, true],
  ]);
  assert.deepEqual(lines.map(segmentCount), [5, 1, 1, 1, 5, 5]);
  assert.deepEqual(jointMarkers(model).map((m) => [m.name, m.type]), [['tip', 'spherical'], ['plate', 'weld']]);
  assert.deepEqual(jointLines({ bodies: [{ name: 'free', L: -1, joint_type: 'free', joint_axes: [] }] }), []);
});

test("a root's parent axis is inertial; others turn with J or K, whichever it is fixed in", () => {
  const [cart, yokeA1, yokeA2, link] = jointLines(model);
  // The cart turns (0.3 rad about z) but its rail does not.
  closeVec(axisDirection(model, cart, frame), [1, 0, 0], 0, 'rail');
  // a1 is fixed in the cart: R_cart^T a1, whatever the yoke's pose.
  closeVec(axisDirection(model, yokeA1, frame), [-Math.sin(0.3), Math.cos(0.3), 0], 1e-15, 'a1');
  // a2 is fixed in the yoke (turned -0.7 about y): x turns to (cos 0.7, 0, sin 0.7).
  closeVec(axisDirection(model, yokeA2, frame), [Math.cos(0.7), 0, Math.sin(0.7)], 1e-15, 'a2');
  // The link's axis is fixed in the yoke, not in the link.
  closeVec(axisDirection(model, link, frame), bodyToInertial(frame[1].e, [0, 0, 1]), 1e-15, 'link axis');
  // a1 and a2 of the universal joint stay perpendicular as it turns: the yoke is the cart
  // turned 0.9 about a1 (cart axes), then 1.3 about a2 (its own).
  const yoke = mul(mul(frame[0].e, axisAngle([0, 1, 0], 0.9)), axisAngle([1, 0, 0], 1.3));
  const moved = frame.map((f, k) => (k === 1 ? { ...f, e: yoke } : f));
  close(dot(axisDirection(model, yokeA1, moved), axisDirection(model, yokeA2, moved)), 0, 1e-15, 'a1 . a2');
});

test('an axis line runs through Q_K, h either way', () => {
  const lines = jointLines(model);
  lines.forEach((l) => {
    const [[from, to]] = lineSegments(model, l, frame, 0.25);
    const u = axisDirection(model, l, frame);
    const q = frame[l.body].q;
    closeVec(from, q.map((c, a) => c - 0.25 * u[a]), 1e-15, `${l.name} from`);
    closeVec(to, q.map((c, a) => c + 0.25 * u[a]), 1e-15, `${l.name} to`);
  });
});

test('a sliding axis has arrowheads at both ends: back 0.25 h, out 0.12 h, normal to it', () => {
  const h = 0.4;
  for (const l of jointLines(model).filter((x) => x.slide)) {
    const segments = lineSegments(model, l, frame, h);
    assert.equal(segments.length, 5);
    const u = axisDirection(model, l, frame);
    const [tail, head] = segments[0];
    segments.slice(1).forEach(([tip, base], i) => {
      closeVec(tip, i < 2 ? tail : head, 0, `${l.name} head ${i} tip`);
      const d = base.map((c, a) => c - tip[a]);
      close(dot(d, u), i < 2 ? 0.25 * h : -0.25 * h, 1e-15, `${l.name} head ${i} back`);
      const out = d.map((c, a) => c - dot(d, u) * u[a]);
      close(Math.hypot(...out), 0.12 * h, 1e-15, `${l.name} head ${i} out`);
    });
    // The two barbs of a head lie on either side of the axis.
    const out = (s) => s[1].map((c, a) => c - s[0][a]);
    close(dot(out(segments[1]), out(segments[2])), (0.25 * h) ** 2 - (0.12 * h) ** 2, 1e-15, `${l.name} barbs`);
  }
});

test('normalTo gives a unit normal', () => {
  for (const u of [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.6, 0.8, 0], [0.36, 0.48, 0.8]]) {
    const n = normalTo(u);
    close(Math.hypot(...n), 1, 1e-15, `|n(${u})|`);
    close(dot(n, u), 0, 1e-15, `n(${u}) . u`);
  }
});

test("an axis line's half length follows the body's size, within 4% and 15% of the view", () => {
  close(axisHalfLength({ semi_axes: [0.1, 0.1, 0.5] }, 5), 0.3, 1e-15, 'a 1 m rod in a 5 m view');
  close(axisHalfLength({ semi_axes: [0.001, 0.001, 0.002] }, 10), 0.4, 1e-15, 'a speck');
  close(axisHalfLength({ semi_axes: [5, 1, 1] }, 10), 1.5, 1e-15, 'a beam');
});
