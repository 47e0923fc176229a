// The four-bar linkage (examples/four_bar.yaml) in headless chromium: its loop closed by the
// hinge `closure` between the rocker's far end and the ground at D = (1, 0, 0). The two
// closure markers coincide and the two hinge axes stay parallel while it plays.
import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { EXAMPLES, kanedyn, readCsv, workDir } from '../support.js';
import { openPage, checkPositions, checkScreenshot, checkQuiet } from './check_page.js';
import { decodePng } from './png.js';
import { CONSTRAINT_HEX } from '../../src/constraints.js';

const dir = workDir('browser-four-bar');
const model = join(EXAMPLES, 'four_bar.yaml');
// 2 s at rows 1 ms apart: between rows, linear interpolation of G and slerp differ from the
// motion by (dt^2 / 8) |a|, below 1e-5 m for the tips' accelerations here (tens of m/s^2).
assert.equal(kanedyn(dir, 'simulate', model, '--t-end', '2', '--dt-out', '0.001', '-o', 'four_bar.csv').code, 0);
assert.equal(kanedyn(dir, 'view', model, 'four_bar.csv').code, 0);
const csv = readCsv(join(dir, 'four_bar.csv'));
const ctx = await openPage(join(dir, 'four_bar.html'));
after(() => ctx.close());

const drawn = async (t) => ctx.page.evaluate((time) => { window.kanedynViewer.seek(time); return window.kanedynViewer.constraints(); }, t);

test('the drawn mass centres are the CSV interpolated, between rows', async () => {
  const r = await checkPositions(ctx.page, csv, 0.12345);
  assert.equal(r.bodies, 3);
});

test('the closure\'s markers coincide and its axes stay parallel while it plays', async () => {
  // The run keeps the loop closed by projection (below 1e-9 m); the page adds the float32
  // Euler parameters (a 1.2 m coupler and 0.9 m rocker turn by 6e-8 rad: 1e-7 m), float32
  // positions in the scene graph (1e-7 m at 1 m), and between rows the interpolation error
  // above: 1e-6 m at the rows, 2e-5 m between.
  let worstRows = 0;
  let worstBetween = 0;
  let worstAxes = 0;
  for (let i = 0; i <= 40; ++i) {
    const t = i * 0.05 + (i % 2 ? 0.00037 : 0);
    const [c] = await drawn(Math.min(t, 2));
    assert.equal(c.name, 'closure');
    assert.equal(c.type, 'hinge');
    const gap = Math.hypot(...c.from.map((x, a) => x - c.to[a]));
    if (i % 2) worstBetween = Math.max(worstBetween, gap);
    else worstRows = Math.max(worstRows, gap);
    // The ground's point is D itself.
    assert.deepEqual(c.to, [1, 0, 0]);
    // The two axis lines (fixed in the rocker, and in the ground) through the two points.
    const [a, b] = c.axes.map(([p, q]) => q.map((x, k) => x - p[k]));
    const cross = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    worstAxes = Math.max(worstAxes, Math.hypot(...cross) / (Math.hypot(...a) * Math.hypot(...b)));
  }
  console.log(`closure gap: ${worstRows.toExponential(2)} m at rows, ${worstBetween.toExponential(2)} m between; axes' sine ${worstAxes.toExponential(2)}`);
  assert.ok(worstRows < 1e-6, `gap at the rows: ${worstRows} m`);
  assert.ok(worstBetween < 2e-5, `gap between the rows: ${worstBetween} m`);
  // Planar motion about z: the axes are z to float32 (the lines' end points are float32).
  assert.ok(worstAxes < 1e-6, `sine between the axes: ${worstAxes}`);
});

test('the closure\'s markers are on the screenshot', async () => {
  await drawn(1.0);
  await checkScreenshot(ctx.page, join(dir, 'four_bar.png'));
  const img = decodePng(await ctx.page.screenshot({ type: 'png' }));
  const HEX = CONSTRAINT_HEX.closure;
  const want = [(HEX >> 16) & 255, (HEX >> 8) & 255, HEX & 255];
  const is = ([r, g, b]) => Math.abs(r - want[0]) + Math.abs(g - want[1]) + Math.abs(b - want[2]) < 12;
  const [c] = await drawn(1.0);
  for (const p of [c.pageFrom, c.pageTo]) {
    let hit = false;
    for (let dy = -1; dy <= 1 && !hit; ++dy) for (let dx = -1; dx <= 1 && !hit; ++dx) hit = is(img.rgb(Math.round(p.x) + dx, Math.round(p.y) + dy));
    assert.ok(hit, `the closure colour at (${p.x}, ${p.y})`);
  }
});

test('no console error and no network request', () => {
  checkQuiet(ctx);
});
