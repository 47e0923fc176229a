// The configuration at any time t: per body G_K (interpolated), eps_K (slerped), and from
// them O_K = G_K - R_K^T r'_K and Q_K = O_J + R_J^T q'_K (O_J the inertial origin for roots).
import { locate, lerp, slerp, bodyToInertial } from './interp.js';

export function createMotion(model, traj) {
  const n = model.bodies.length;
  const t = traj.columns[0];
  const cols = model.bodies.map((b) => ({
    g: ['x', 'y', 'z'].map((s) => traj.column(`${b.name}.${s}`)),
    e: ['e1', 'e2', 'e3', 'e4'].map((s) => traj.column(`${b.name}.${s}`)),
  }));
  const frame = model.bodies.map(() => ({ g: [0, 0, 0], e: [0, 0, 0, 1], o: [0, 0, 0], q: [0, 0, 0] }));
  const p = [0, 0, 0, 0];
  const q = [0, 0, 0, 0];
  const v = [0, 0, 0];

  /** Fills and returns the frame at time t (clamped to the rows' range). */
  function at(time) {
    const { i, u } = locate(t, time);
    const j = Math.min(i + 1, traj.rows - 1);
    for (let k = 0; k < n; ++k) {
      const c = cols[k];
      const f = frame[k];
      for (let a = 0; a < 3; ++a) f.g[a] = lerp(c.g[a][i], c.g[a][j], u);
      for (let a = 0; a < 4; ++a) {
        p[a] = c.e[a][i];
        q[a] = c.e[a][j];
      }
      slerp(p, q, u, f.e);
      bodyToInertial(f.e, model.bodies[k].com, v);
      for (let a = 0; a < 3; ++a) f.o[a] = f.g[a] - v[a];
    }
    // Q_K needs O_J: bodies come after their lower body (L(K) < K), so one pass in order.
    for (let k = 0; k < n; ++k) {
      const b = model.bodies[k];
      const f = frame[k];
      if (b.L < 0) {
        for (let a = 0; a < 3; ++a) f.q[a] = b.joint[a];
      } else {
        const J = frame[b.L];
        bodyToInertial(J.e, b.joint, v);
        for (let a = 0; a < 3; ++a) f.q[a] = J.o[a] + v[a];
      }
    }
    return frame;
  }

  return { at, times: t, start: t[0], end: t[traj.rows - 1] };
}
