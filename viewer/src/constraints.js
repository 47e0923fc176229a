// The constraints of a model as the scene draws them (docs/model-format.md, "Constraints"):
// a rolling disc's wheel and its contact point on the ground plane; a ball, hinge or
// distance constraint's two attachment points, the hinge's two axes and the distance's line.
// Pure functions of the page's model and motion.at(t), in the conventions of
// src/constraints.cpp, so that the page draws the points the equations hold together.
import { bodyToInertial } from './interp.js';

/**
 * Colours: a wheel's rim and spokes, its contact point, and a loop closure's points and
 * lines (the point of `body` solid, the point of `other` a wire ball around it).
 */
export const CONSTRAINT_HEX = { rim: 0x262626, contact: 0x00a050, closure: 0xd01890 };

/** True when the page's model has constraints. */
export function hasConstraints(model) {
  return Array.isArray(model.constraints) && model.constraints.length > 0;
}

/** The rolling discs: the constraints of type rolling_disc, with their index. */
export function rollingDiscs(model) {
  return (model.constraints || []).map((c, i) => ({ ...c, index: i })).filter((c) => c.type === 'rolling_disc');
}

/** The loop closures: the ball, hinge and distance constraints, with their index. */
export function closures(model) {
  return (model.constraints || []).map((c, i) => ({ ...c, index: i })).filter((c) => c.type !== 'rolling_disc');
}

/**
 * The inertial position of the point of body `body` at `at` (from O_K, body-K components) at
 * the configuration `frame`: O_K + R_K^T at; for the ground (body -1) `at` itself.
 */
export function pointOf(frame, body, at, out = [0, 0, 0]) {
  if (body < 0) {
    for (let a = 0; a < 3; ++a) out[a] = at[a];
    return out;
  }
  const f = frame[body];
  bodyToInertial(f.e, at, out);
  for (let a = 0; a < 3; ++a) out[a] += f.o[a];
  return out;
}

/** Inertial components of a direction fixed in `body` (given in its components; ground: as is). */
export function directionOf(frame, body, v, out = [0, 0, 0]) {
  if (body < 0) {
    for (let a = 0; a < 3; ++a) out[a] = v[a];
    return out;
  }
  return bodyToInertial(frame[body].e, v, out);
}

const dot = (u, v) => u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
const cross = (u, v) => [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];

/**
 * A rolling disc at `frame`: its centre C, its axle a (inertial, unit), the direction d from C
 * to the contact and the contact point P = C + radius d, with d = (a (a . n) - n) / |a x n|,
 * the unit vector of the disc's plane most nearly along -n (the model's definition; the
 * same expression as src/constraints.cpp). With the axle along n (|a x n| below 1e-9, where
 * the run would have failed) the contact is undefined: d and contact are null.
 */
export function discContact(c, frame) {
  const centre = pointOf(frame, c.body, c.at);
  const axis = directionOf(frame, c.body, c.axis);
  const n = c.plane_normal;
  const s = Math.hypot(...cross(axis, n));
  if (!(s > 1e-9)) return { centre, axis, d: null, contact: null };
  const an = dot(axis, n);
  const d = axis.map((x, i) => (x * an - n[i]) / s);
  return { centre, axis, d, contact: centre.map((x, i) => x + c.radius * d[i]) };
}

/**
 * A loop closure at `frame`: `from`, the point of `body` (at), and `to`, the point of `other`
 * (other_at; the ground's is inertial), which the constraint holds together (ball, hinge)
 * or `length` apart (distance); for a hinge also its two axes, `axis` fixed in body and
 * `otherAxis` fixed in other, inertial unit vectors that the constraint keeps parallel.
 */
export function closurePoints(c, frame) {
  const r = { from: pointOf(frame, c.body, c.at), to: pointOf(frame, c.other, c.other_at) };
  if (c.type === 'hinge') {
    r.axis = directionOf(frame, c.body, c.axis);
    r.otherAxis = directionOf(frame, c.other, c.other_axis);
  }
  return r;
}

/**
 * The plane all rolling discs roll on when they share one and it is normal to `up` (the
 * ground the wheels touch: the scene's grid lies there): the point of it along up from the
 * origin, up . p = offset (n . up). Null without discs, or when they roll on different or
 * tilted planes.
 */
export function discGround(model, up) {
  const discs = rollingDiscs(model);
  if (!discs.length) return null;
  let level = null;
  for (const c of discs) {
    const nu = dot(c.plane_normal, up);
    if (Math.abs(Math.abs(nu) - 1) > 1e-9) return null;
    const h = c.plane_offset * nu;
    if (level !== null && Math.abs(h - level) > 1e-9 * Math.max(1, Math.abs(h))) return null;
    level = h;
  }
  return level;
}
