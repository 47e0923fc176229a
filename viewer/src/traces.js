// Path traces and the model's frames (docs/model-format.md, "Frames"): which points can be
// traced (each body's mass centre, each frame's origin), where a point is at a configuration,
// and its path over the run up to a time. Pure functions of the page's model and motion.at(t).
import { pointOf } from './constraints.js';
import { bodyToInertial, locate } from './interp.js';

/** The model's frames (an empty list when it has none). */
export function modelFrames(model) {
  return Array.isArray(model.frames) ? model.frames : [];
}

/**
 * The points a page can trace: every body's mass centre G_K, then every frame's origin, as
 * { name, kind: 'body' | 'frame', index }. Names are unique among bodies and frames.
 */
export function tracePoints(model) {
  return [
    ...model.bodies.map((b, k) => ({ name: b.name, kind: 'body', index: k })),
    ...modelFrames(model).map((f, i) => ({ name: f.name, kind: 'frame', index: i })),
  ];
}

/** The inertial position of a trace point at the configuration `frame`. */
export function pointAt(model, p, frame, out = [0, 0, 0]) {
  if (p.kind === 'body') {
    const g = frame[p.index].g;
    for (let a = 0; a < 3; ++a) out[a] = g[a];
    return out;
  }
  const f = model.frames[p.index];
  return pointOf(frame, f.body, f.at, out);
}

/**
 * A frame's pose at the configuration `frame`: its origin O_K + R_K^T at and its axes'
 * directions (inertial unit vectors x, y, z). The frame's `rotation` (x, y, z, w) maps frame
 * to body-K components, and the body's Euler parameters body-K to inertial components.
 */
export function framePose(model, i, frame) {
  const f = model.frames[i];
  const origin = pointOf(frame, f.body, f.at);
  const axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1]].map((e) => {
    const inBody = bodyToInertial(f.rotation, e, [0, 0, 0]);
    return f.body < 0 ? inBody : bodyToInertial(frame[f.body].e, inBody, [0, 0, 0]);
  });
  return { origin, axes };
}

/**
 * The path of trace point p over the run: its positions at the rows' times (every
 * stride-th row and the last when there are more than maxPoints rows), as { times, points }
 * with points packed x, y, z.
 */
export function tracePath(model, motion, p, maxPoints = 5000) {
  const rows = motion.times.length;
  const stride = Math.max(1, Math.ceil(rows / maxPoints));
  const kept = [];
  for (let r = 0; r < rows; r += stride) kept.push(r);
  if (kept[kept.length - 1] !== rows - 1) kept.push(rows - 1);
  const times = new Float64Array(kept.length);
  const points = new Float64Array(kept.length * 3);
  const x = [0, 0, 0];
  kept.forEach((r, i) => {
    times[i] = motion.times[r];
    pointAt(model, p, motion.at(times[i]), x);
    points.set(x, i * 3);
  });
  return { times, points };
}

/**
 * The path up to time t: the number of whole segments between kept points at or before t,
 * and whether a last, partial segment runs from the last of them to the point's position at
 * t (the trace then ends where the point is drawn, not at the row before).
 */
export function tracedSegments(times, t) {
  if (times.length < 2 || t <= times[0]) return { whole: 0, partial: false };
  const { i, u } = locate(times, t);
  if (u >= 1) return { whole: i + 1, partial: false };
  return { whole: i, partial: u > 0 };
}
