// The three.js scene: an inertia-equivalent ellipsoid per body in its body frame, the links
// O_J -> Q_K -> O_K, body axes, the joints of a jointed model, its constraints (wheels,
// contact points, loop closures), a ground grid and the gravity direction.
import {
  AmbientLight, ArrowHelper, AxesHelper, BoxGeometry, CircleGeometry, Color, DirectionalLight,
  DoubleSide, GridHelper, Group, Mesh, MeshBasicMaterial, MeshStandardMaterial, PerspectiveCamera,
  Quaternion, Scene, SphereGeometry, TorusGeometry, Vector3, WebGLRenderer,
} from 'three';
import { LineMaterial } from 'three/examples/jsm/lines/LineMaterial.js';
import { LineSegments2 } from 'three/examples/jsm/lines/LineSegments2.js';
import { LineSegmentsGeometry } from 'three/examples/jsm/lines/LineSegmentsGeometry.js';
import { fitView } from './fit.js';
import {
  JOINT_HEX, MARKER_HEX, axisHalfLength, hasJoints, jointLines, jointMarkers, lineSegments, segmentCount,
} from './joints.js';
import {
  CONSTRAINT_HEX, closurePoints, closures, discContact, hasConstraints, rollingDiscs,
} from './constraints.js';
import { modelFrames, pointAt, tracePath, tracePoints, tracedSegments } from './traces.js';

export const BACKGROUND = 0xf4f5f7;
/** Body axes x, y, z: red, green, blue (darker than pure, to read on the light background). */
export const AXIS_HEX = [0xd02020, 0x109010, 0x2040e0];
const AXIS_COLOURS = AXIS_HEX.map((c) => new Color(c));

/** A colour of its own for body k: hues a golden angle apart. */
export function bodyColour(k) {
  return new Color().setHSL(((k * 137.508) % 360) / 360, 0.65, 0.5);
}

/** Widths in CSS pixels: WebGL draws its own lines 1 device pixel wide whatever is asked. */
export const LINK_WIDTH = 2;
export const JOINT_WIDTH = 3;
export const FRAME_WIDTH = 3;
export const TRACE_WIDTH = 2;
/** A trace's colour: its body's for a mass centre; for a frame, dark teal. */
export const FRAME_TRACE_HEX = 0x007a7a;
export function traceColour(model, p) {
  return p.kind === 'body' ? bodyColour(p.index) : new Color(FRAME_TRACE_HEX);
}

/**
 * The bodies whose links O_J -> Q_K -> O_K are drawn: those the page's data marks `linked`
 * (a joint other than free, a bushing, or a force on s'_K between K and J). A free body
 * with nothing between it and J moves on its own, and a line from O_J would read as a tether.
 */
export function linkedBodies(model) {
  return model.bodies.map((b, k) => (b.linked === false ? -1 : k)).filter((k) => k >= 0);
}

/**
 * True when WebGL draws on the CPU (SwiftShader, llvmpipe: a browser without a GPU, as in
 * headless tests): there multisampling costs several times the rest of a frame (83 ms
 * against 17 ms a frame for the 64-link chain), so it is left off.
 */
export function softwareRenderer() {
  const gl = document.createElement('canvas').getContext('webgl2') || document.createElement('canvas').getContext('webgl');
  if (!gl) return false;
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  const name = String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
  const lose = gl.getExtension('WEBGL_lose_context');
  if (lose) lose.loseContext();
  return /swiftshader|llvmpipe|software/i.test(name);
}

export function createScene(canvas, model, motion) {
  const software = softwareRenderer();
  const renderer = new WebGLRenderer({ canvas, antialias: !software });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  const scene = new Scene();
  scene.background = new Color(BACKGROUND);
  scene.add(new AmbientLight(0xffffff, 0.8));
  const sun = new DirectionalLight(0xffffff, 2.0);
  scene.add(sun);

  const fit = fitView(model, motion);
  const up = new Vector3(...fit.up);
  // Light from above and from the camera's side, whatever the model's up.
  sun.position.set(...fit.up.map((u, a) => 2 * u + fit.view[a]));
  const camera = new PerspectiveCamera(40, 1, fit.radius / 1000, fit.radius * 100);
  camera.up.copy(up);

  const sphere = new SphereGeometry(1, 32, 16);
  const bodies = model.bodies.map((b, k) => {
    const frame = new Group(); // origin O_K, axes of body K
    const mesh = new Mesh(sphere, new MeshStandardMaterial({ color: bodyColour(k), roughness: 0.6 }));
    mesh.position.set(...b.com); // G_K at r'_K in body axes
    mesh.quaternion.set(...b.principal);
    mesh.scale.set(...b.semi_axes);
    mesh.userData.body = k;
    frame.add(mesh);
    const axes = new AxesHelper(1.6 * Math.max(...b.semi_axes, 1e-3 * fit.radius));
    axes.setColors(AXIS_COLOURS[0], AXIS_COLOURS[1], AXIS_COLOURS[2]);
    axes.visible = false;
    frame.add(axes);
    scene.add(frame);
    return { frame, mesh, axes };
  });

  // Two segments per linked body: O_J -> Q_K (fixed in J) and Q_K -> O_K (the translation s'_K).
  const n = model.bodies.length;
  const linked = linkedBodies(model);
  // Drawn as screen-space quads (three.js's LineSegments2), so that the lines have a width;
  // each frame rewrites the position array in place (setPositions keeps the array).
  const linkPositions = new Float32Array(Math.max(linked.length, 1) * 4 * 3);
  const linkGeometry = new LineSegmentsGeometry();
  linkGeometry.setPositions(linkPositions);
  const lineMaterials = [new LineMaterial({ color: 0x222222, linewidth: LINK_WIDTH })];
  const links = new LineSegments2(linkGeometry, lineMaterials[0]);
  links.frustumCulled = false;
  links.visible = linked.length > 0;
  scene.add(links);

  // The model's frames: small axes (x red, y green, z blue) at each frame's origin, fixed in
  // its body (or the ground), drawn over the ellipsoids (a tool point usually lies in one).
  const frameAxes = new Group();
  frameAxes.visible = modelFrames(model).length > 0;
  scene.add(frameAxes);
  const frameLength = 0.08 * fit.markerScale;
  lineMaterials.push(new LineMaterial({
    vertexColors: true, linewidth: FRAME_WIDTH, depthTest: false, depthWrite: false,
  }));
  const frameMarks = modelFrames(model).map((f) => {
    const holder = new Group(); // the frame: origin at `at`, axes turned by `rotation`
    holder.position.set(...f.at);
    holder.quaternion.set(...f.rotation);
    const geometry = new LineSegmentsGeometry();
    geometry.setPositions([0, 0, 0, frameLength, 0, 0, 0, 0, 0, 0, frameLength, 0, 0, 0, 0, 0, 0, frameLength]);
    geometry.setColors(AXIS_COLOURS.flatMap((c) => [...c.toArray(), ...c.toArray()]));
    const axes = new LineSegments2(geometry, lineMaterials[lineMaterials.length - 1]);
    axes.frustumCulled = false;
    axes.renderOrder = 3;
    holder.add(axes);
    // In the body's frame group, which place() puts at O_K turned by eps_K; the ground's
    // frames are inertial.
    const parent = f.body < 0 ? frameAxes : new Group();
    if (f.body >= 0) {
      frameAxes.add(parent);
      parent.userData.body = f.body;
    }
    parent.add(holder);
    return { f, holder, parent };
  });

  // The ground: a plane normal to gravity (fit.js, groundLevel).
  const grid = new GridHelper(fit.gridSize, fit.gridDivisions, 0x9aa0a8, 0xc8ccd2);
  grid.quaternion.setFromUnitVectors(new Vector3(0, 1, 0), up);
  grid.position.set(...fit.ground);
  scene.add(grid);
  if (fit.hasGravity) {
    const g = up.clone().negate();
    const length = 0.3 * fit.radius;
    const tail = new Vector3(...fit.ground).addScaledVector(up, length * 1.1)
      .add(new Vector3(...fit.side).multiplyScalar(fit.radius * 1.1));
    const arrow = new ArrowHelper(g, tail, length, 0x3060c0, 0.25 * length, 0.12 * length);
    scene.add(arrow);
  }

  // The joints: axis lines through Q_K and markers at it, drawn over the ellipsoids (a joint
  // point usually lies inside one).
  const joints = new Group();
  joints.visible = hasJoints(model);
  scene.add(joints);
  const lines = jointLines(model);
  const halves = lines.map((l) => axisHalfLength(model.bodies[l.body], fit.radius));
  const jointSegments = lines.reduce((s, l) => s + segmentCount(l), 0);
  const jointPositions = new Float32Array(jointSegments * 6);
  const jointColours = new Float32Array(jointSegments * 6);
  {
    const turn = new Color(JOINT_HEX.turn);
    const slide = new Color(JOINT_HEX.slide);
    let s = 0;
    for (const l of lines) {
      for (let i = 0; i < segmentCount(l); ++i, ++s) {
        const c = i === 0 && l.turn ? turn : slide;
        for (let end = 0; end < 2; ++end) c.toArray(jointColours, s * 6 + end * 3);
      }
    }
  }
  const jointGeometry = new LineSegmentsGeometry();
  if (jointSegments > 0) {
    jointGeometry.setPositions(jointPositions);
    jointGeometry.setColors(jointColours);
  }
  lineMaterials.push(new LineMaterial({
    vertexColors: true, linewidth: JOINT_WIDTH, depthTest: false, depthWrite: false,
  }));
  const jointLinesObject = new LineSegments2(jointGeometry, lineMaterials[1]);
  jointLinesObject.visible = jointSegments > 0; // (welds only: markers, no lines to draw)
  jointLinesObject.frustumCulled = false;
  jointLinesObject.renderOrder = 2;
  joints.add(jointLinesObject);
  const marks = jointMarkers(model).map((m) => {
    // The same size for every marker: 1.5% of the model's size (fit.js, markerScale; a cube's half edge).
    const r = 0.015 * fit.markerScale;
    const geometry = m.type === 'weld' ? new BoxGeometry(2 * r, 2 * r, 2 * r) : new SphereGeometry(r, 16, 8);
    const mesh = new Mesh(geometry, new MeshBasicMaterial({ color: MARKER_HEX[m.type], depthTest: false, depthWrite: false }));
    mesh.renderOrder = 2;
    joints.add(mesh);
    return { ...m, mesh };
  });

  /** The joint lines' segments at `frame`, in inertial coordinates, into the line buffer. */
  function placeJoints(frame) {
    let s = 0;
    lines.forEach((l, i) => {
      for (const [a, b] of lineSegments(model, l, frame, halves[i])) {
        jointPositions.set(a, s * 6);
        jointPositions.set(b, s * 6 + 3);
        ++s;
      }
    });
    if (jointSegments > 0) jointGeometry.attributes.instanceStart.data.needsUpdate = true;
    for (const m of marks) {
      const qk = frame[m.body].q;
      m.mesh.position.set(qk[0], qk[1], qk[2]);
      // A weld's cube turns with the body.
      const e = frame[m.body].e;
      if (m.type === 'weld') m.mesh.quaternion.set(e[0], e[1], e[2], e[3]);
    }
  }

  // The constraints. A rolling disc's wheel is a rim (a torus of the disc's radius about its
  // axle, at its centre), a translucent disc in the body's colour and three spokes, fixed in
  // the wheel's body frame so that it turns with it; its contact point is a green ball on the ground with the radius
  // from the centre to it, recomputed from the wheel's pose every frame. A loop closure marks
  // the point of `body` with a solid ball and the point of `other` with a wire ball around
  // it (they coincide when the constraint holds), joins a distance constraint's two points
  // with a line and draws a hinge's two axes through its points.
  const constrained = new Group();
  constrained.visible = hasConstraints(model);
  scene.add(constrained);
  const discs = rollingDiscs(model);
  const loops = closures(model);
  const markRadius = 0.015 * fit.markerScale; // the joints' markers' size
  const axisHalf = 0.06 * fit.markerScale;
  const wheels = discs.map((c) => {
    const wheel = new Group();
    wheel.position.set(...c.at);
    const axle = new Vector3(...c.axis).normalize();
    wheel.quaternion.setFromUnitVectors(new Vector3(0, 0, 1), axle); // the torus's axis is z
    const r = c.radius;
    const tube = 0.035 * r;
    const rimMaterial = new MeshStandardMaterial({ color: CONSTRAINT_HEX.rim, roughness: 0.8 });
    wheel.add(new Mesh(new TorusGeometry(r, tube, 12, 72), rimMaterial));
    for (let i = 0; i < 3; ++i) {
      const spoke = new Mesh(new BoxGeometry(2 * r, 0.5 * tube, 0.5 * tube), rimMaterial);
      spoke.rotation.z = (i * Math.PI) / 3;
      wheel.add(spoke);
    }
    const face = new Mesh(new CircleGeometry(r, 72), new MeshBasicMaterial({
      color: bodyColour(c.body), transparent: true, opacity: 0.45, side: DoubleSide, depthWrite: false,
    }));
    wheel.add(face);
    // In the body's frame (turning with it), shown with the other constraints. The wheel
    // stands for its body: the body's ellipsoid (a wheel's is a flat disc larger than the
    // wheel, I = m r^2 / 2 about the axle giving a semi-axis of r sqrt(5) / 2) is hidden
    // while the wheel is shown.
    bodies[c.body].frame.add(wheel);
    bodies[c.body].mesh.visible = !constrained.visible;
    const contact = new Mesh(new SphereGeometry(markRadius, 16, 8), new MeshBasicMaterial({
      color: CONSTRAINT_HEX.contact, depthTest: false, depthWrite: false,
    }));
    contact.renderOrder = 2;
    constrained.add(contact);
    return { c, wheel, contact };
  });
  const closureMarks = loops.map((c) => {
    const from = new Mesh(new SphereGeometry(markRadius, 16, 8), new MeshBasicMaterial({
      color: CONSTRAINT_HEX.closure, depthTest: false, depthWrite: false,
    }));
    const to = new Mesh(new SphereGeometry(1.8 * markRadius, 12, 6), new MeshBasicMaterial({
      color: CONSTRAINT_HEX.closure, wireframe: true, depthTest: false, depthWrite: false,
    }));
    from.renderOrder = 2;
    to.renderOrder = 2;
    constrained.add(from, to);
    return { c, from, to };
  });
  // Line segments: per disc the radius to its contact, per distance its line, per hinge its
  // two axes.
  const constraintSegmentCount = (c) => (c.type === 'hinge' ? 2 : c.type === 'ball' ? 0 : 1);
  const constraintSegments = (model.constraints || []).reduce((n0, c) => n0 + constraintSegmentCount(c), 0);
  const constraintPositions = new Float32Array(constraintSegments * 6);
  const constraintColours = new Float32Array(constraintSegments * 6);
  const constraintGeometry = new LineSegmentsGeometry();
  {
    let seg = 0;
    for (const c of model.constraints || []) {
      const colour = new Color(c.type === 'rolling_disc' ? CONSTRAINT_HEX.contact : CONSTRAINT_HEX.closure);
      for (let i = 0; i < constraintSegmentCount(c); ++i, ++seg) {
        for (let end = 0; end < 2; ++end) colour.toArray(constraintColours, seg * 6 + end * 3);
      }
    }
    if (constraintSegments > 0) {
      constraintGeometry.setPositions(constraintPositions);
      constraintGeometry.setColors(constraintColours);
    }
  }
  lineMaterials.push(new LineMaterial({
    vertexColors: true, linewidth: JOINT_WIDTH, depthTest: false, depthWrite: false,
  }));
  const constraintLines = new LineSegments2(constraintGeometry, lineMaterials[2]);
  constraintLines.visible = constraintSegments > 0;
  constraintLines.frustumCulled = false;
  constraintLines.renderOrder = 2;
  constrained.add(constraintLines);

  /** The constraints' markers and lines at `frame`, from the bodies' poses. */
  function placeConstraints(frame) {
    const segs = [];
    let w = 0;
    let l = 0;
    for (const c of model.constraints || []) {
      if (c.type === 'rolling_disc') {
        const { contact } = wheels[w++];
        const p = discContact(c, frame);
        contact.visible = p.contact !== null;
        if (p.contact) {
          contact.position.set(...p.contact);
          segs.push([p.centre, p.contact]);
        } else {
          segs.push([p.centre, p.centre]);
        }
        continue;
      }
      const m = closureMarks[l++];
      const p = closurePoints(c, frame);
      m.from.position.set(...p.from);
      m.to.position.set(...p.to);
      if (c.type === 'distance') segs.push([p.from, p.to]);
      if (c.type === 'hinge') {
        for (const [at, u] of [[p.from, p.axis], [p.to, p.otherAxis]]) {
          segs.push([at.map((x, a) => x - axisHalf * u[a]), at.map((x, a) => x + axisHalf * u[a])]);
        }
      }
    }
    segs.forEach(([a, b], i) => {
      constraintPositions.set(a, i * 6);
      constraintPositions.set(b, i * 6 + 3);
    });
    if (constraintSegments > 0) constraintGeometry.attributes.instanceStart.data.needsUpdate = true;
  }

  const q = new Quaternion();
  const v = new Vector3();
  // Path traces: per traced point its path over the run (traces.js), drawn up to the current
  // time; built when first turned on.
  const points = tracePoints(model);
  const traces = new Map(); // name -> { p, path, positions, geometry, line }
  const traced = new Group();
  scene.add(traced);
  let lastFrame = null;
  let lastTime = motion.start;
  function makeTrace(p) {
    const path = tracePath(model, motion, p);
    const count = path.times.length;
    const segments = Math.max(count - 1, 1);
    const positions = new Float32Array(segments * 6);
    for (let i = 0; i + 1 < count; ++i) {
      positions.set(path.points.subarray(i * 3, i * 3 + 6), i * 6);
    }
    const geometry = new LineSegmentsGeometry();
    geometry.setPositions(positions);
    // Vertex colours, as the joints': LineMaterial's `color` is drawn lighter than the colour
    // (encoded to sRGB twice), the vertex colours as given.
    const colours = new Float32Array(segments * 6);
    const colour = traceColour(model, p);
    for (let i = 0; i < segments * 2; ++i) colour.toArray(colours, i * 3);
    geometry.setColors(colours);
    const material = new LineMaterial({ vertexColors: true, linewidth: TRACE_WIDTH });
    lineMaterials.push(material);
    if (resolution) material.resolution.copy(resolution);
    const line = new LineSegments2(geometry, material);
    line.frustumCulled = false;
    traced.add(line);
    const t = { p, path, positions, geometry, line };
    traces.set(p.name, t);
    return t;
  }
  const at3 = [0, 0, 0];
  /** Shows trace t's path up to `time`, ending at its point in `frame` (the drawn one). */
  function placeTrace(t, time, frame) {
    const { whole, partial } = tracedSegments(t.path.times, time);
    const { positions, path, geometry } = t;
    // Restore the segment a previous time cut short, then cut the one at `time`.
    if (t.cut !== undefined && t.cut * 3 + 6 <= path.points.length) {
      positions.set(path.points.subarray(t.cut * 3 + 3, t.cut * 3 + 6), t.cut * 6 + 3);
    }
    t.cut = undefined;
    if (partial) {
      positions.set(pointAt(model, t.p, frame, at3), whole * 6 + 3);
      t.cut = whole;
    }
    geometry.instanceCount = whole + (partial ? 1 : 0);
    geometry.attributes.instanceStart.data.needsUpdate = true;
  }
  /** Turns the trace of the body or frame called `name` on or off; false for no such point. */
  function setTrace(name, on) {
    const p = points.find((x) => x.name === name);
    if (!p) return false;
    let t = traces.get(name);
    if (!t && !on) return true;
    if (!t) t = makeTrace(p);
    t.line.visible = on;
    if (on && lastFrame) placeTrace(t, lastTime, lastFrame);
    return true;
  }
  /** The names of the traces shown. */
  function tracesShown() {
    return [...traces.values()].filter((t) => t.line.visible).map((t) => t.p.name);
  }
  /** Trace `name` as drawn now: its points (inertial), the last one where the point is. */
  function drawnTrace(name) {
    const t = traces.get(name);
    if (!t || !t.line.visible) return null;
    const count = t.geometry.instanceCount;
    const out = [];
    for (let i = 0; i < count; ++i) {
      if (i === 0) out.push([...t.positions.subarray(0, 3)]);
      out.push([...t.positions.subarray(i * 6 + 3, i * 6 + 6)]);
    }
    return out;
  }

  /** Places every body at the configuration `frame` (motion.at(t)) at time `time`. */
  function place(frame, time = motion.start) {
    let link = 0;
    for (let k = 0; k < n; ++k) {
      const f = frame[k];
      // [R]^T maps body to inertial components; as a unit quaternion it is (e1, e2, e3; e4).
      q.set(f.e[0], f.e[1], f.e[2], f.e[3]);
      bodies[k].frame.quaternion.copy(q);
      bodies[k].frame.position.set(f.o[0], f.o[1], f.o[2]);
      const b = model.bodies[k];
      if (linked[link] !== k) continue;
      ++link;
      const j = b.L < 0 ? null : frame[b.L].o;
      const base = (link - 1) * 12;
      for (let a = 0; a < 3; ++a) {
        linkPositions[base + a] = j ? j[a] : 0;
        linkPositions[base + 3 + a] = f.q[a];
        linkPositions[base + 6 + a] = f.q[a];
        linkPositions[base + 9 + a] = f.o[a];
      }
    }
    linkGeometry.attributes.instanceStart.data.needsUpdate = true;
    if (lines.length || marks.length) placeJoints(frame);
    if (hasConstraints(model)) placeConstraints(frame);
    for (const m of frameMarks) {
      if (m.f.body < 0) continue;
      m.parent.position.copy(bodies[m.f.body].frame.position);
      m.parent.quaternion.copy(bodies[m.f.body].frame.quaternion);
    }
    lastFrame = frame;
    lastTime = time;
    for (const t of traces.values()) if (t.line.visible) placeTrace(t, time, frame);
    scene.updateMatrixWorld();
  }

  /** The model's frames as drawn: per frame its origin and its three axes' tips (inertial). */
  function drawnFrames() {
    return frameMarks.map((m) => {
      const origin = m.holder.getWorldPosition(new Vector3());
      const tip = (e) => m.holder.localToWorld(new Vector3(...e.map((x) => x * frameLength)));
      return {
        name: m.f.name,
        body: m.f.body,
        origin: origin.toArray(),
        tips: [[1, 0, 0], [0, 1, 0], [0, 0, 1]].map((e) => tip(e).toArray()),
        length: frameLength,
      };
    });
  }

  function setFramesVisible(on) {
    frameAxes.visible = on;
  }

  /** The mass centres as drawn: each ellipsoid's centre in inertial coordinates. */
  function drawnCentres() {
    return bodies.map((b, k) => {
      b.mesh.getWorldPosition(v);
      return { name: model.bodies[k].name, x: v.x, y: v.y, z: v.z };
    });
  }

  /** The canvas's size in CSS pixels, which the line widths are measured in. */
  let resolution = null;
  function setResolution(width, height) {
    for (const m of lineMaterials) m.resolution.set(width, height);
    resolution = lineMaterials[0].resolution.clone();
  }

  function setAxesVisible(on) {
    for (const b of bodies) b.axes.visible = on;
  }

  function setJointsVisible(on) {
    joints.visible = on;
  }

  /** The joint lines as drawn: per axis its body, type and end points (inertial). */
  function drawnJoints() {
    let s = 0;
    return lines.map((l) => {
      const p = jointPositions;
      const r = { body: l.body, name: l.name, type: l.type, in: l.in, from: [...p.subarray(s * 6, s * 6 + 3)], to: [...p.subarray(s * 6 + 3, s * 6 + 6)] };
      s += segmentCount(l);
      return r;
    });
  }

  function setConstraintsVisible(on) {
    constrained.visible = on;
    for (const { c, wheel } of wheels) {
      wheel.visible = on;
      bodies[c.body].mesh.visible = !on;
    }
  }

  /**
   * The constraints as drawn, in the model's order, inertial coordinates from the scene
   * graph: a rolling disc's wheel centre, axle (the wheel's local z), radius and contact
   * marker (null when undefined); a closure's two markers, and a hinge's axis lines.
   */
  function drawnConstraints() {
    let w = 0;
    let l = 0;
    let seg = 0;
    const p = constraintPositions;
    const segment = () => {
      const r = [[...p.subarray(seg * 6, seg * 6 + 3)], [...p.subarray(seg * 6 + 3, seg * 6 + 6)]];
      ++seg;
      return r;
    };
    const world = (o) => o.getWorldPosition(new Vector3()).toArray();
    return (model.constraints || []).map((c) => {
      const r = { name: c.name, type: c.type, body: c.body };
      if (c.type === 'rolling_disc') {
        const { wheel, contact } = wheels[w++];
        r.centre = world(wheel);
        r.axis = new Vector3(0, 0, 1).applyQuaternion(wheel.getWorldQuaternion(new Quaternion())).toArray();
        r.radius = c.radius;
        r.contact = contact.visible ? world(contact) : null;
        r.radiusLine = segment();
        return r;
      }
      const m = closureMarks[l++];
      r.from = world(m.from);
      r.to = world(m.to);
      if (c.type === 'distance') r.line = segment();
      if (c.type === 'hinge') r.axes = [segment(), segment()];
      return r;
    });
  }

  return {
    software, renderer, scene, camera, bodies, fit, place, drawnCentres, setAxesVisible, setJointsVisible, drawnJoints, sun,
    setResolution, setConstraintsVisible, drawnConstraints, drawnFrames, setFramesVisible,
    setTrace, tracesShown, drawnTrace, tracePoints: points, linkedCount: linked.length,
  };
}
