// Fitting the model in view, whatever its size: the box of all mass centres over the run
// (sampled), of the O_K and Q_K points and the rolling discs' contact points, grown by the
// largest ellipsoid or wheel radius.
import { discContact, discGround, rollingDiscs } from './constraints.js';

/** Up is against gravity; without gravity, +z. */
export function upDirection(gravity) {
  const norm = Math.hypot(...gravity);
  return norm > 0 ? gravity.map((c) => -c / norm) : [0, 0, 1];
}

/** Any unit vector normal to u. */
function normalTo(u) {
  const a = Math.abs(u[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
  const d = a[0] * u[0] + a[1] * u[1] + a[2] * u[2];
  const w = a.map((c, i) => c - d * u[i]);
  const n = Math.hypot(...w);
  return w.map((c) => c / n);
}

/**
 * Where the grid lies along up (the plane up . p = level): the plane the wheels roll on when
 * they share one normal to up; else, under gravity, the ground plane through the inertial
 * origin normal to gravity (a model's floor: a pendulum's pivot above it, a chain hanging
 * below it); without gravity there is no floor, and the grid lies below the box lo..hi of
 * the whole motion, so that it never cuts a body.
 */
export function groundLevel(model, up, lo, hi) {
  const wheels = discGround(model, up);
  if (wheels !== null) return wheels;
  if (Math.hypot(...model.gravity) > 0) return 0;
  let lowest = Infinity;
  for (const x of [lo[0], hi[0]]) for (const y of [lo[1], hi[1]]) for (const z of [lo[2], hi[2]]) {
    lowest = Math.min(lowest, x * up[0] + y * up[1] + z * up[2]);
  }
  return lowest;
}

export function fitView(model, motion, samples = 200) {
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  const grow = (p) => {
    for (let a = 0; a < 3; ++a) {
      lo[a] = Math.min(lo[a], p[a]);
      hi[a] = Math.max(hi[a], p[a]);
    }
  };
  const rows = motion.times.length;
  const step = Math.max(1, Math.floor(rows / samples));
  const discs = rollingDiscs(model);
  for (let r = 0; r < rows; r += step) {
    const frame = motion.at(motion.times[r]);
    for (const f of frame) {
      grow(f.g);
      grow(f.o);
      grow(f.q);
    }
    for (const c of discs) {
      const { contact } = discContact(c, frame);
      if (contact) grow(contact);
    }
  }
  for (const f of motion.at(motion.end)) grow(f.g);
  const size = Math.max(...model.bodies.map((b) => Math.max(...b.semi_axes)), ...discs.map((c) => c.radius));
  for (let a = 0; a < 3; ++a) {
    lo[a] -= size;
    hi[a] += size;
  }
  const centre = lo.map((l, a) => 0.5 * (l + hi[a]));
  const radius = Math.max(0.5 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]), 1e-3);
  const up = upDirection(model.gravity);
  const level = groundLevel(model, up, lo, hi);
  const c = centre[0] * up[0] + centre[1] * up[1] + centre[2] * up[2];
  const ground = centre.map((x, a) => x + (level - c) * up[a]);
  // Cells a power of ten (about a fifth of the radius or less), as many as span the motion.
  const gridCell = 10 ** Math.floor(Math.log10(radius / 5));
  const gridDivisions = Math.max(2, Math.ceil((2.4 * radius) / gridCell));
  const gridSize = gridDivisions * gridCell;
  // Looking from the side and somewhat above: a direction normal to up, tilted 25 degrees.
  const side = normalTo(up);
  const other = [
    up[1] * side[2] - up[2] * side[1], up[2] * side[0] - up[0] * side[2], up[0] * side[1] - up[1] * side[0],
  ];
  const view = side.map((s, a) => -0.6 * s - 0.8 * other[a] + 0.45 * up[a]);
  const vn = Math.hypot(...view);
  // The markers' scale: the model's own size (its radius at the start about the first body's
  // mass centre), at most the view's radius, so that a vehicle's markers stay its size
  // however far it travels (and the follow camera comes close).
  const size0 = Math.min(radius, followRadius(model, motion.at(motion.start), 0));
  return {
    centre, radius, up, ground, gridSize, gridDivisions, gridCell, side, markerScale: size0,
    view: view.map((x) => x / vn),
    hasGravity: Math.hypot(...model.gravity) > 0,
  };
}

/** Camera distance that shows a sphere of this radius whole at vertical field of view fov
 * (degrees) and aspect ratio (width / height). */
export function fitDistance(radius, fov, aspect) {
  const half = (fov * Math.PI) / 360;
  const horizontal = Math.atan(Math.tan(half) * aspect);
  return (1.1 * radius) / Math.sin(Math.min(half, horizontal));
}

/**
 * The radius of the model at one configuration about body k's mass centre: the largest
 * distance from G_k to any body's ellipsoid (its G plus its largest semi-axis), O, and joint
 * point Q if the body is on another (a root's Q is fixed in the inertial frame, perhaps far
 * behind a vehicle), and to a wheel's rim and contact point: what a camera following body k
 * must show.
 */
export function followRadius(model, frame, k) {
  const g = frame[k].g;
  let far = 0;
  const grow = (p, r = 0) => { far = Math.max(far, Math.hypot(p[0] - g[0], p[1] - g[1], p[2] - g[2]) + r); };
  frame.forEach((f, j) => {
    grow(f.g, Math.max(...model.bodies[j].semi_axes));
    grow(f.o);
    if (model.bodies[j].L >= 0) grow(f.q);
  });
  for (const c of rollingDiscs(model)) {
    const { centre, contact } = discContact(c, frame);
    grow(centre, c.radius);
    if (contact) grow(contact);
  }
  return Math.max(far, 1e-3);
}
