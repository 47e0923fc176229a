// The follow camera and path traces on the Whipple bicycle (examples/bicycle.yaml), 2 s of its
// run at 5 m/s: written with `kanedyn view --follow rear_frame --trace rear_frame,front_wheel`,
// the page opens close to the bicycle and keeps it there while it rides 10 m, and draws the
// two mass centres' paths up to the time shown. The readout under the plot has values at load.
import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { EXAMPLES, SOURCE, interpolate, kanedyn, readCsv, workDir } from '../support.js';
import { openPage, checkPositions, checkQuiet } from './check_page.js';
import { decodePng } from './png.js';

const dir = workDir('browser-follow-trace');
const model = join(EXAMPLES, 'bicycle.yaml');
assert.equal(kanedyn(dir, 'simulate', model, '--t-end', '2', '-o', 'bicycle.csv').code, 0);
assert.equal(kanedyn(dir, 'view', model, 'bicycle.csv', '--follow', 'rear_frame', '--trace', 'rear_frame', '--trace', 'front_wheel', '-o', 'follow.html').code, 0);
const csv = readCsv(join(dir, 'bicycle.csv'));
const ctx = await openPage(join(dir, 'follow.html'));
after(() => ctx.close());

const v = (f, ...args) => ctx.page.evaluate(f, ...args);

test('the readout under the plot has values at load, before the mouse moves', async () => {
  const legend = await v(() => window.kanedynViewer.legend(0));
  assert.equal(legend.length, 2, legend.join(' | '));
  assert.equal(legend[0], 't0');
  assert.ok(!legend.some((l) => l.includes('--')), legend.join(' | '));
  assert.match(legend[1], /^energy2,022\.86/);
});

test('an unknown body or frame is an error naming it', () => {
  const r = kanedyn(dir, 'view', model, 'bicycle.csv', '--follow', 'saddle', '-o', 'x.html');
  assert.equal(r.code, 1);
  assert.match(r.err, /--follow 'saddle': the model has no body 'saddle' \(its bodies: rear_frame, rear_wheel, front_frame, front_wheel\)/);
  const s = kanedyn(dir, 'view', model, 'bicycle.csv', '--trace', 'rear_frame,pedal', '-o', 'x.html');
  assert.equal(s.code, 1);
  assert.match(s.err, /--trace 'pedal': the model has no body or frame 'pedal'/);
});

test('the page follows the rear frame from the start, close in', async () => {
  assert.equal(await v(() => window.kanedynViewer.followed()), 0);
  assert.equal(await ctx.page.$eval('#follow', (e) => e.value), '0');
  // The bicycle on the page: the extent of its wheels' contact points and mass centres
  // (about 1.1 m by 1 m) spans a good part of the 624 px wide stage, not the 35 px of a
  // view of the whole 10 m run.
  const extent = () => v(() => {
    const k = window.kanedynViewer;
    const p = [...k.constraints().map((c) => c.pageContact), ...k.projectedCentres()];
    const xs = p.map((q) => q.x);
    const ys = p.map((q) => q.y);
    return Math.hypot(Math.max(...xs) - Math.min(...xs), Math.max(...ys) - Math.min(...ys));
  });
  await v(() => window.kanedynViewer.seek(0.5));
  const near = await extent();
  await v(() => window.kanedynViewer.follow(-1));
  await ctx.page.click('#fit');
  await v(() => window.kanedynViewer.seek(0.5));
  const whole = await extent();
  console.log(`the bicycle spans ${near.toFixed(0)} px followed, ${whole.toFixed(0)} px in the whole run's view`);
  assert.ok(near > 150, `followed: ${near} px`);
  assert.ok(whole < near / 3, `the whole run's view: ${whole} px`);
  await v(() => window.kanedynViewer.follow(0));
});

test('following keeps the camera\'s offset from the mass centre: a translation', async () => {
  const at = (t) => v((time) => {
    const k = window.kanedynViewer;
    k.seek(time);
    return { camera: k.camera(), centre: k.projectedCentres()[0], g: k.bodyPositions()[0] };
  }, t);
  const a = await at(0.2);
  const b = await at(1.8);
  // It rode about 8 m; the camera moved with it, by the same vector (round-off of 10 m).
  const moved = Math.hypot(b.g.x - a.g.x, b.g.y - a.g.y, b.g.z - a.g.z);
  assert.ok(moved > 5, `the rear frame moves ${moved} m`);
  const offset = (s) => s.camera.position.map((p, i) => p - [s.g.x, s.g.y, s.g.z][i]);
  offset(a).forEach((o, i) => assert.ok(Math.abs(o - offset(b)[i]) < 1e-9, `offset ${i}: ${o} then ${offset(b)[i]}`));
  assert.deepEqual(b.camera.target.map((x) => x.toFixed(9)), [b.g.x, b.g.y, b.g.z].map((x) => x.toFixed(9)));
  // On the page, its mass centre stays put.
  assert.ok(Math.hypot(a.centre.x - b.centre.x, a.centre.y - b.centre.y) < 0.5, 'the followed mass centre stays on the page');
});

test('the traces are the mass centres\' paths up to the time shown', async () => {
  assert.deepEqual(await v(() => window.kanedynViewer.traces()), ['rear_frame', 'front_wheel']);
  const t = 1.234;
  await checkPositions(ctx.page, csv, t);
  for (const name of ['rear_frame', 'front_wheel']) {
    const path = await v((n) => window.kanedynViewer.drawnTrace(n), name);
    const rows = csv.rows.filter((r) => r[0] <= t);
    // One point per row up to t, then the point at t (float32 in the line buffer: 1e-5 m
    // at 10 m is above its 6e-8 relative step).
    assert.equal(path.length, rows.length + 1, `${name}: ${path.length} points`);
    const c = ['x', 'y', 'z'].map((a) => csv.header.indexOf(`${name}.${a}`));
    rows.forEach((r, i) => c.forEach((col, a) => assert.ok(Math.abs(path[i][a] - r[col]) < 1e-5, `${name} row ${i}`)));
    const last = path[path.length - 1];
    c.forEach((col, a) => assert.ok(Math.abs(last[a] - interpolate(csv, col, t)) < 1e-5, `${name} at t`));
  }
  // Off and on again through its checkbox.
  await ctx.page.click('#trace-front_wheel');
  assert.deepEqual(await v(() => window.kanedynViewer.traces()), ['rear_frame']);
  assert.equal(await v(() => window.kanedynViewer.drawnTrace('front_wheel')), null);
  await ctx.page.click('#trace-front_wheel');
  assert.deepEqual(await v(() => window.kanedynViewer.traces()), ['rear_frame', 'front_wheel']);
});

/** Body k's colour on the page (scene.js: hue k * 137.508 degrees, saturation 0.65, lightness 0.5). */
function hsl(k) {
  const h = ((k * 137.508) % 360) / 60;
  const c = (1 - Math.abs(2 * 0.5 - 1)) * 0.65;
  const x = c * (1 - Math.abs((h % 2) - 1));
  const m = 0.5 - c / 2;
  const [r, g, b] = [[c, x, 0], [x, c, 0], [0, c, x], [0, x, c], [x, 0, c], [c, 0, x]][Math.floor(h) % 6];
  // three.js's setHSL takes the components in its working colour space, linear: the pixel
  // is their sRGB encoding.
  const srgb = (c) => (c <= 0.0031308 ? 12.92 * c : 1.055 * c ** (1 / 2.4) - 0.055);
  return [r, g, b].map((u) => Math.round(srgb(u + m) * 255));
}

test('the traces are drawn in their bodies\' colours', async () => {
  const t = 1.5;
  // A point of the rear frame's path 0.3 s back (in view, clear of the bicycle), on the page.
  const page = await v((time) => {
    const k = window.kanedynViewer;
    k.seek(time);
    const path = k.drawnTrace('rear_frame');
    return k.project(path[Math.floor(path.length * 0.8)]);
  }, t);
  const colour = hsl(0);
  const near = async () => {
    const img = decodePng(await ctx.page.screenshot({ type: 'png' }));
    let best = Infinity;
    for (let dy = -2; dy <= 2; ++dy) {
      for (let dx = -2; dx <= 2; ++dx) {
        const [r, g, b] = img.rgb(Math.round(page.x) + dx, Math.round(page.y) + dy);
        best = Math.min(best, Math.abs(r - colour[0]) + Math.abs(g - colour[1]) + Math.abs(b - colour[2]));
      }
    }
    return best;
  };
  const on = await near();
  await ctx.page.click('#trace-rear_frame');
  await v((time) => window.kanedynViewer.seek(time), t);
  const off = await near();
  await ctx.page.click('#trace-rear_frame');
  console.log(`colour distance at the trace: ${on} with it, ${off} without`);
  assert.ok(on <= 30, `the trace's colour at (${page.x}, ${page.y}): distance ${on}`);
  assert.ok(off > 60, `without the trace: distance ${off}`);
});

test('a screenshot: the bicycle followed, with its traces', async () => {
  await v(() => window.kanedynViewer.seek(1.6));
  const png = await ctx.page.screenshot({ type: 'png', path: join(SOURCE, 'docs/viewer-bicycle-follow.png') });
  assert.ok(png.length < 150000, `${png.length} bytes`);
});

test('no console error and no network request', () => {
  checkQuiet(ctx);
});
