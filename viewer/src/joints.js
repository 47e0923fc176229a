// The joints of a jointed model as the scene draws them: each joint axis as a line through
// the joint point Q_K, turning with the body it is fixed in (J, the inertial frame for a
// root, or K), with arrowheads at both ends when the joint slides along it; a marker at Q_K
// for a spherical or a weld joint. Pure functions of the page's model and motion.at(t).
import { bodyToInertial } from './interp.js';

/** Line colours: an axis the body turns about, and the arrowheads of one it slides along. */
export const JOINT_HEX = { turn: 0x6a0dc8, slide: 0xe07000 };
/** Marker colours: a spherical joint's ball, a weld's cube. */
export const MARKER_HEX = { spherical: 0x6a0dc8, weld: 0x404040 };

/** True when the page's model is jointed (its bodies have a joint_type). */
export function hasJoints(model) {
  return model.bodies.some((b) => typeof b.joint_type === 'string');
}

/**
 * The axis lines: per axis of every body { body, name, type, axis, in, turn, slide }, turn
 * true when the body turns about it, slide when it slides along it, as the page's joint_axes
 * say (the joint table's answer: a prismatic axis slides only, a cylindrical or screw axis
 * both).
 */
export function jointLines(model) {
  const lines = [];
  model.bodies.forEach((b, k) => {
    for (const a of b.joint_axes || []) {
      const type = b.joint_type;
      lines.push({
        body: k, name: b.name, type, axis: a.axis, in: a.in,
        turn: a.turn !== false, slide: a.slide === true,
      });
    }
  });
  return lines;
}

/** The markers: { body, name, type } per spherical or weld joint. */
export function jointMarkers(model) {
  const marks = [];
  model.bodies.forEach((b, k) => {
    if (b.joint_type === 'spherical' || b.joint_type === 'weld') marks.push({ body: k, name: b.name, type: b.joint_type });
  });
  return marks;
}

/** Any unit vector normal to the unit vector u. */
export function normalTo(u) {
  const a = Math.abs(u[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
  const d = a[0] * u[0] + a[1] * u[1] + a[2] * u[2];
  const w = a.map((c, i) => c - d * u[i]);
  const n = Math.hypot(...w);
  return w.map((c) => c / n);
}

/**
 * The inertial components of a line's axis (and of a fixed normal to it, for arrowheads) at
 * the configuration `frame`: the axis's components are those of J (the inertial frame's for a
 * root) when it is in "parent", of K when in "body".
 */
export function axisDirection(model, line, frame, out = [0, 0, 0], vb = line.axis) {
  const b = model.bodies[line.body];
  const e = line.in === 'body' ? frame[line.body].e : b.L < 0 ? null : frame[b.L].e;
  if (!e) {
    for (let a = 0; a < 3; ++a) out[a] = vb[a];
    return out;
  }
  return bodyToInertial(e, vb, out);
}

/**
 * The inertial end points of a line at `frame`: [Q - h u, Q + h u] with Q = Q_K and u the
 * axis (h the half length), then for a sliding axis the arrowheads, two segments at each end
 * from the tip back 0.25 h along u and out 0.12 h either way along a normal fixed in the same
 * body. An array of [from, to] pairs.
 */
export function lineSegments(model, line, frame, h) {
  const q = frame[line.body].q;
  const u = axisDirection(model, line, frame);
  const at = (s, t = 0, n = null) => q.map((c, a) => c + s * u[a] + (n ? t * n[a] : 0));
  const segments = [[at(-h), at(h)]];
  if (line.slide) {
    const n = axisDirection(model, line, frame, [0, 0, 0], normalTo(line.axis));
    for (const end of [-1, 1]) {
      const tip = at(end * h);
      for (const side of [-1, 1]) segments.push([tip, at(end * 0.75 * h, side * 0.12 * h, n)]);
    }
  }
  return segments;
}

/** Segments a line draws: 1, and 4 more for a sliding axis's arrowheads. */
export function segmentCount(line) {
  return line.slide ? 5 : 1;
}

/**
 * The half length of every axis line: 0.6 of the largest semi-axis of the body's ellipsoid,
 * kept between 4% and 15% of the view's radius so that a needle or a slab still shows a
 * readable line and a long limb no spear.
 */
export function axisHalfLength(body, radius) {
  const h = 0.6 * Math.max(...body.semi_axes);
  return Math.min(Math.max(h, 0.04 * radius), 0.15 * radius);
}
