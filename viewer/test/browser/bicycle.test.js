// The Whipple bicycle (examples/bicycle.yaml) in headless chromium: 1 s of its self-stable run
// at 5 m/s after a roll rate of 0.5 rad/s. Its two rolling-disc wheels are drawn as discs on
// the wheel bodies, and their contact markers stay on the ground z = 0 while it plays.
import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { EXAMPLES, SOURCE, interpolate, kanedyn, readCsv, workDir } from '../support.js';
import { openPage, checkPositions, checkScreenshot, checkPlots, checkQuiet } from './check_page.js';
import { decodePng } from './png.js';
import { bodyToInertial } from '../../src/interp.js';
import { CONSTRAINT_HEX } from '../../src/constraints.js';

const dir = workDir('browser-bicycle');
const model = join(EXAMPLES, 'bicycle.yaml');
// 1 s: it travels 5 m, leans and steers back (docs/bicycle.md).
assert.equal(kanedyn(dir, 'simulate', model, '--t-end', '1', '-o', 'bicycle.csv').code, 0);
assert.equal(kanedyn(dir, 'view', model, 'bicycle.csv').code, 0);
const csv = readCsv(join(dir, 'bicycle.csv'));
const ctx = await openPage(join(dir, 'bicycle.html'));
after(() => ctx.close());

const RADIUS = { rear_contact: 0.3, front_contact: 0.35 };
const WHEEL = { rear_contact: 'rear_wheel', front_contact: 'front_wheel' };
const drawn = async (t) => ctx.page.evaluate((time) => { window.kanedynViewer.seek(time); return window.kanedynViewer.constraints(); }, t);
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const col = (name) => csv.header.indexOf(name);

test('the drawn mass centres are the CSV interpolated, between rows', async () => {
  const r = await checkPositions(ctx.page, csv, 0.4567);
  assert.equal(r.bodies, 4);
});

test('the constraints toggle is there and on', async () => {
  assert.equal(await ctx.page.$eval('#constraints', (e) => e.checked), true);
});

test('two wheel discs, each about its wheel\'s axle through its centre', async () => {
  // At a row (0.5 s) the page's pose is the CSV's, with the Euler parameters as float32
  // (relative step 6e-8): the axle to 1e-6.
  const t = 0.5;
  const got = await drawn(t);
  assert.deepEqual(got.map((c) => [c.name, c.type]), [['rear_contact', 'rolling_disc'], ['front_contact', 'rolling_disc']]);
  const row = csv.rows.find((r) => Math.abs(r[0] - t) < 1e-9);
  for (const c of got) {
    const w = WHEEL[c.name];
    assert.equal(c.radius, RADIUS[c.name]);
    // The wheel's centre is its mass centre (com [0, 0, 0]): the CSV's G, to 1e-6 m.
    for (const [a, s] of ['x', 'y', 'z'].entries()) assert.ok(Math.abs(c.centre[a] - interpolate(csv, col(`${w}.${s}`), t)) < 1e-6, `${c.name} centre ${s}`);
    const e = ['e1', 'e2', 'e3', 'e4'].map((s) => row[col(`${w}.${s}`)]);
    const want = bodyToInertial(e, [0, 1, 0]);
    for (let a = 0; a < 3; ++a) assert.ok(Math.abs(c.axis[a] - want[a]) < 1e-6, `${c.name} axle[${a}]: ${c.axis[a]} vs ${want[a]}`);
  }
});

test('the contact markers stay on the ground, on each wheel\'s rim, while it plays', async () => {
  // At 40 times over the run, most between rows. The run keeps n . P = 0 to its projection's
  // tolerance (below 1e-9 m); the page adds the float32 Euler parameters (0.35 m x 6e-8) and,
  // between rows 0.01 s apart, linear interpolation of G and slerp, off by (dt^2 / 8) |a| for
  // the centres' accelerations (a few m/s^2 here while it leans and steers: ~1e-4 m at most).
  // The contact's height error is of second order in the lean's error, so below both: 1e-5 m
  // between rows, 1e-6 m at the rows.
  let worstBetween = 0;
  let worstAtRows = 0;
  for (let i = 0; i <= 40; ++i) {
    const t = i * 0.025 + (i % 2 ? 0.0037 : 0);
    const got = await drawn(Math.min(t, 1));
    for (const c of got) {
      assert.ok(c.contact, `${c.name} has a contact at t = ${t}`);
      const h = Math.abs(c.contact[2]);
      if (i % 2) worstBetween = Math.max(worstBetween, h);
      else worstAtRows = Math.max(worstAtRows, h);
      // On the rim: r from the centre, in the wheel's plane. The marker's position is float32
      // in three.js's scene graph: 1e-6 m.
      const d = c.contact.map((x, a) => x - c.centre[a]);
      assert.ok(Math.abs(Math.hypot(...d) - c.radius) < 1e-6, `${c.name}: |P - C| = ${Math.hypot(...d)}`);
      assert.ok(Math.abs(dot(d, c.axis)) < 1e-6, `${c.name}: (P - C) . a = ${dot(d, c.axis)}`);
      // Below the centre: the lowest point of the rim.
      assert.ok(c.contact[2] < c.centre[2] - 0.9 * c.radius, `${c.name}: the contact is under the centre`);
    }
  }
  console.log(`contact heights: ${worstAtRows.toExponential(2)} m at rows, ${worstBetween.toExponential(2)} m between`);
  assert.ok(worstAtRows < 1e-6, `contact height at the rows: ${worstAtRows} m`);
  assert.ok(worstBetween < 1e-5, `contact height between the rows: ${worstBetween} m`);
});

test('the contact markers and the wheels are on the screenshot; the toggle hides them', async () => {
  const t = 0.5;
  await drawn(t);
  // Closer: the view fits the whole run (5 m), and at 0.5 s the bicycle is at its middle,
  // where the camera looks; the mouse wheel zooms in towards it (18 notches: about 3x).
  for (let i = 0; i < 18; ++i) {
    await ctx.page.mouse.move(300, 250);
    await ctx.page.mouse.wheel({ deltaY: -100 });
  }
  await drawn(t);
  // The picture of docs/bicycle.md, with the energy plot beside it.
  await checkScreenshot(ctx.page, join(SOURCE, 'docs/bicycle-viewer.png'));
  const CONTACT = [(CONSTRAINT_HEX.contact >> 16) & 255, (CONSTRAINT_HEX.contact >> 8) & 255, CONSTRAINT_HEX.contact & 255];
  const isContact = ([r, g, b]) => Math.abs(r - CONTACT[0]) + Math.abs(g - CONTACT[1]) + Math.abs(b - CONTACT[2]) < 12;
  const count = async () => {
    const img = decodePng(await ctx.page.screenshot({ type: 'png' }));
    let n = 0;
    for (let y = 0; y < img.height; ++y) for (let x = 0; x < img.width; ++x) if (isContact(img.rgb(x, y))) ++n;
    return { img, n };
  };
  const on = await count();
  const got = await drawn(t);
  for (const c of got) {
    const x0 = Math.round(c.pageContact.x);
    const y0 = Math.round(c.pageContact.y);
    let hit = false;
    for (let dy = -1; dy <= 1 && !hit; ++dy) for (let dx = -1; dx <= 1 && !hit; ++dx) hit = isContact(on.img.rgb(x0 + dx, y0 + dy));
    assert.ok(hit, `${c.name}: the contact colour at its marker (${x0}, ${y0})`);
  }
  await ctx.page.click('#constraints');
  await drawn(t);
  const off = await count();
  await ctx.page.click('#constraints');
  await drawn(t);
  console.log(`contact-coloured pixels: ${on.n} with the constraints, ${off.n} without`);
  assert.ok(on.n > off.n + 20, `contact-coloured pixels: ${on.n} with, ${off.n} without`);
  assert.equal((await count()).n, on.n);
});

test('the ground grid is the wheels\' plane z = 0', async () => {
  const ground = await ctx.page.evaluate(() => window.kanedynViewer.ground());
  assert.equal(ground[2], 0);
});

test('the plots are drawn; the energy axis has an offset and a scale', async () => {
  await checkPlots(ctx.page);
  // The energy, 2022.86 J, drifts by about 1e-6 J in the run: the ticks are differences from
  // an offset, in a power of ten, not the same "2022.86" repeated.
  const axis = await ctx.page.evaluate(() => window.kanedynViewer.plotAxis(0));
  console.log(`energy axis: '${axis.text}' over ${axis.labels.join(', ')}`);
  assert.match(axis.text, /^\u00d71e-[0-9]+ \+2022\.86/);
  assert.ok(axis.labels.length >= 2 && new Set(axis.labels).size === axis.labels.length, axis.labels.join(', '));
});

test('no console error and no network request', () => {
  checkQuiet(ctx);
});
