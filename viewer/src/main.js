// The page: reads its data, builds the scene, the playback controls and the plots, and
// exposes window.kanedynViewer for tests and scripts (docs/viewer.md, "Page hook").
import { readPageData, decodeTrajectory } from './data.js';
import { createMotion } from './motion.js';
import { createScene, bodyColour } from './scene.js';
import { fitDistance, followRadius } from './fit.js';
import { modePlotColumns } from './modeplot.js';
import { createPlot } from './plots.js';
import { createPlayback } from './playback.js';
import { h, layout } from './ui.js';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { Raycaster, Vector2, Vector3 } from 'three';
import './style.css';

function start() {
  const d = readPageData(document);
  const model = d.model;
  const traj = decodeTrajectory(d);
  const motion = createMotion(model, traj);
  const ui = layout(document.body, d);
  document.title = `${model.name || model.file} - kanedyn view`;

  const view = createScene(ui.canvas, model, motion);
  const { renderer, camera, scene } = view;
  const controls = new OrbitControls(camera, ui.canvas);
  const fit = view.fit;
  controls.target.set(...fit.centre);

  let t = motion.start;
  let dirty = true;
  let follow = -1;
  const followed = new Vector3();
  let frame = motion.at(t);

  function resize() {
    const w = ui.stage.clientWidth;
    const hgt = ui.stage.clientHeight;
    renderer.setSize(w, hgt, false);
    view.setResolution(w, hgt);
    camera.aspect = w / Math.max(hgt, 1);
    camera.updateProjectionMatrix();
    dirty = true;
  }
  function fitCamera() {
    resize();
    const dist = fitDistance(fit.radius, camera.fov, camera.aspect);
    camera.position.set(...fit.centre.map((c, a) => c + dist * fit.view[a]));
    controls.target.set(...fit.centre);
    camera.near = dist / 1000;
    camera.far = dist * 100;
    camera.updateProjectionMatrix();
    controls.update();
    dirty = true;
  }

  const plots = [];
  const redrawPlots = () => plots.forEach((p) => p && p.redraw(false, false));
  function seek(time) {
    t = Math.min(Math.max(time, motion.start), motion.end);
    frame = motion.at(t);
    view.place(frame, t);
    if (follow >= 0) {
      const g = frame[follow].g;
      const delta = new Vector3(g[0], g[1], g[2]).sub(followed);
      camera.position.add(delta);
      controls.target.add(delta);
      followed.set(g[0], g[1], g[2]);
      controls.update();
    }
    playback.show(t);
    plots.forEach((p) => p && p.showTime());
    redrawPlots();
    dirty = true;
  }

  const playback = createPlayback(ui, motion, { seek, getTime: () => t });

  // Plots: energy (a mode page: the mode's coordinates that move), and the picked columns in
  // a second plot.
  const plotWidth = () => Math.max(ui.plots.clientWidth - 8, 200);
  const plotOpts = (title) => ({ width: plotWidth(), height: 180, getTime: () => t, seek, title });
  plots[0] = d.mode_columns
    ? createPlot(ui.energyPlot, traj, modePlotColumns(traj, d.mode_columns), plotOpts('mode coordinates (rad, m)'))
    : createPlot(ui.energyPlot, traj, ['energy'], plotOpts('energy (J)'));
  const picked = [];
  function redoPicked() {
    if (plots[1]) plots[1].destroy();
    plots[1] = null;
    ui.pickedPlot.replaceChildren();
    if (picked.length) plots[1] = createPlot(ui.pickedPlot, traj, picked, plotOpts('picked columns'));
    ui.chips.replaceChildren(...picked.map((name) => h('button', {
      class: 'chip', title: 'remove', onclick: () => { picked.splice(picked.indexOf(name), 1); redoPicked(); },
    }, `${name} \u00d7`)));
  }
  function pick(name) {
    if (traj.index(name) === undefined || name === 't' || picked.includes(name)) return false;
    picked.push(name);
    redoPicked();
    return true;
  }
  ui.picker.addEventListener('change', () => {
    if (pick(ui.picker.value.trim())) ui.picker.value = '';
  });
  ui.picker.addEventListener('keydown', (e) => {
    if (e.key === 'Enter' && pick(ui.picker.value.trim())) ui.picker.value = '';
  });

  // Follow a body: the camera looks at its mass centre from the direction it looked from,
  // close enough to show the model as it is now (not the whole run), and then moves with it,
  // keeping its offset (a translation: the view does not turn with the body).
  function setFollow(k) {
    follow = k;
    ui.follow.value = String(k);
    if (follow >= 0) {
      const g = frame[follow].g;
      const dir = camera.position.clone().sub(controls.target).normalize();
      const dist = fitDistance(followRadius(model, frame, follow), camera.fov, camera.aspect);
      controls.target.set(g[0], g[1], g[2]);
      camera.position.copy(controls.target).addScaledVector(dir, dist);
      camera.near = dist / 1000;
      camera.updateProjectionMatrix();
      followed.set(g[0], g[1], g[2]);
      controls.update();
    }
    dirty = true;
  }
  ui.follow.addEventListener('change', () => setFollow(Number(ui.follow.value)));
  function setTrace(name, on) {
    if (!view.setTrace(name, on)) return false;
    ui.traceBoxes.get(name).checked = on;
    dirty = true;
    return true;
  }
  ui.traceBoxes.forEach((box, name) => box.addEventListener('change', () => setTrace(name, box.checked)));
  ui.frames.addEventListener('change', () => { view.setFramesVisible(ui.frames.checked); dirty = true; });
  ui.axes.addEventListener('change', () => { view.setAxesVisible(ui.axes.checked); dirty = true; });
  ui.joints.addEventListener('change', () => { view.setJointsVisible(ui.joints.checked); dirty = true; });
  ui.constraints.addEventListener('change', () => { view.setConstraintsVisible(ui.constraints.checked); dirty = true; });
  ui.fit.addEventListener('click', fitCamera);
  controls.addEventListener('change', () => { dirty = true; });

  // Names on hover.
  const ray = new Raycaster();
  const pointer = new Vector2();
  const meshes = view.bodies.map((b) => b.mesh);
  ui.canvas.addEventListener('pointermove', (e) => {
    const r = ui.canvas.getBoundingClientRect();
    pointer.set(((e.clientX - r.left) / r.width) * 2 - 1, -((e.clientY - r.top) / r.height) * 2 + 1);
    ray.setFromCamera(pointer, camera);
    const hit = ray.intersectObjects(meshes, false)[0];
    if (hit) {
      const k = hit.object.userData.body;
      ui.tip.textContent = `${k + 1} ${model.bodies[k].name}`;
      ui.tip.style.borderColor = `#${bodyColour(k).getHexString()}`;
      ui.tip.style.left = `${e.clientX - r.left + 12}px`;
      ui.tip.style.top = `${e.clientY - r.top + 12}px`;
      ui.tip.hidden = false;
    } else {
      ui.tip.hidden = true;
    }
  });
  ui.canvas.addEventListener('pointerleave', () => { ui.tip.hidden = true; });

  // The frame loop: advance when playing, render when something changed. work[] holds the
  // milliseconds each rendered frame took (update and draw), for the frame-time hook.
  const work = [];
  let last = performance.now();
  function tick(now) {
    const dt = Math.min((now - last) / 1000, 0.25);
    last = now;
    const start0 = performance.now();
    const next = playback.advance(t, dt);
    if (next !== t) seek(next);
    if (dirty) {
      renderer.render(scene, camera);
      dirty = false;
      work.push(performance.now() - start0);
      if (work.length > 2000) work.shift();
    }
    requestAnimationFrame(tick);
  }
  window.addEventListener('resize', () => {
    resize();
    plots.forEach((p) => p && p.setSize({ width: plotWidth(), height: 180 }));
  });

  view.place(frame, t);
  fitCamera();
  // What the page was written to show (kanedyn view --follow, --trace).
  if (d.trace) {
    for (const name of d.trace) setTrace(name, true);
    ui.traceList.open = true;
  }
  if (d.follow) setFollow(model.bodies.findIndex((b) => b.name === d.follow));
  seek(t);
  renderer.render(scene, camera);
  requestAnimationFrame(tick);

  const project = (p) => {
    const v = new Vector3(p.x, p.y, p.z).project(camera);
    const r = ui.canvas.getBoundingClientRect();
    return { x: r.left + ((v.x + 1) / 2) * r.width, y: r.top + ((1 - v.y) / 2) * r.height };
  };
  window.kanedynViewer = {
    ready: true,
    rows: traj.rows,
    rowsInFile: d.rows_in_file,
    softwareRendering: view.software,
    stride: d.stride,
    start: motion.start,
    end: motion.end,
    time: () => t,
    seek: (time) => { seek(time); renderer.render(scene, camera); dirty = false; return t; },
    play: () => playback.setPlaying(true),
    pause: () => playback.setPlaying(false),
    playing: () => playback.playing(),
    setSpeed: (s) => playback.setSpeed(s),
    /** The mass centres as drawn now (inertial, m). */
    bodyPositions: () => view.drawnCentres(),
    /** Where the drawn mass centres are on the page (CSS pixels). */
    projectedCentres: () => view.drawnCentres().map((p) => ({ name: p.name, ...project(p) })),
    /** The joint axis lines as drawn now: end points inertial (m) and on the page (CSS pixels). */
    jointAxes: () => view.drawnJoints().map((j) => ({
      ...j,
      pageFrom: project({ x: j.from[0], y: j.from[1], z: j.from[2] }),
      pageTo: project({ x: j.to[0], y: j.to[1], z: j.to[2] }),
    })),
    /**
     * The constraints as drawn now (inertial, m): per rolling disc its wheel's centre, axle,
     * radius and contact marker, per closure its two markers (docs/viewer.md, "Page hook");
     * pageContact, pageFrom and pageTo on the page (CSS pixels).
     */
    constraints: () => view.drawnConstraints().map((c) => {
      const page = (p) => (p ? project({ x: p[0], y: p[1], z: p[2] }) : null);
      if (c.type === 'rolling_disc') return { ...c, pageCentre: page(c.centre), pageContact: page(c.contact) };
      return { ...c, pageFrom: page(c.from), pageTo: page(c.to) };
    }),
    /** The model's frames as drawn: per frame its origin and its axes' tips (inertial). */
    frames: () => view.drawnFrames().map((f) => ({
      ...f,
      pageOrigin: project({ x: f.origin[0], y: f.origin[1], z: f.origin[2] }),
      pageTips: f.tips.map((p) => project({ x: p[0], y: p[1], z: p[2] })),
    })),
    /** Turns the trace of a body's mass centre or a frame on or off (false: no such name). */
    trace: (name, on = true) => setTrace(name, on),
    /** A trace as drawn now: its points (inertial), the last where the point is; null when off. */
    drawnTrace: (name) => view.drawnTrace(name),
    /** The names of the traces shown. */
    traces: () => view.tracesShown(),
    /** The body followed (its index; -1 none), and follow(k) to follow another. */
    followed: () => follow,
    follow: (k) => { setFollow(k); seek(t); renderer.render(scene, camera); dirty = false; },
    /** The bodies whose links O_J -> Q_K -> O_K are drawn (their number). */
    linkCount: view.linkedCount,
    /** Where an inertial point [x, y, z] is on the page (CSS pixels). */
    project: (p) => project({ x: p[0], y: p[1], z: p[2] }),
    /** The camera: its position and target (inertial, m). */
    camera: () => ({ position: camera.position.toArray(), target: controls.target.toArray() }),
    /** The page's values of a column (a copy). */
    column: (name) => Array.from(traj.column(name) || []),
    /** The columns plot i shows, and the text of its legend (the readout). */
    plotColumns: (i) => plots[i].series.slice(1).map((s) => s.label),
    legend: (i) => [...plots[i].root.querySelectorAll('.u-legend tr')].map((tr) => tr.textContent.trim()),
    /** A point of the ground grid's plane (inertial, m). */
    ground: () => [...fit.ground],
    /** Page x (CSS pixels) of time `time` on plot i, and the vertical middle of its plot area. */
    plotPoint: (i, time) => {
      const p = plots[i];
      const r = p.over.getBoundingClientRect();
      return { x: r.left + p.valToPos(time, 'x'), y: r.top + r.height / 2 };
    },
    /** The value axis of plot i: its tick labels and offset/scale text ('' when none). */
    plotAxis: (i) => ({ labels: [...plots[i].kanedynAxis.labels], text: plots[i].kanedynAxis.text }),
    plotCanvases: () => plots.filter(Boolean).map((p) => p.ctx.canvas),
    pick,
    /** Milliseconds of work of the last rendered frames (update and draw). */
    frameTimes: () => work.slice(),
    clearFrameTimes: () => { work.length = 0; },
    /**
     * What the renderer holds: the ids of every geometry and material in the scene, the
     * counts of compiled programs, geometries and textures, and whether the canvas is
     * multisampled. Unchanged by playing, unless something is rebuilt per frame.
     */
    resources: () => {
      const ids = [];
      scene.traverse((o) => {
        if (o.geometry) ids.push(o.geometry.uuid);
        if (o.material) [].concat(o.material).forEach((m) => ids.push(m.uuid));
      });
      return {
        ids,
        programs: renderer.info.programs.length,
        geometries: renderer.info.memory.geometries,
        textures: renderer.info.memory.textures,
        multisampled: renderer.getContext().getContextAttributes().antialias,
      };
    },
  };
}

start();
