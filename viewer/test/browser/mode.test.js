// `kanedyn view --mode`: the eight-body figure at rest on its bushings (kanedyn equilibrium), its
// first mode animated. The drawn mass centres swing about the rest pose: half a period on, each
// is displaced the other way by the same amount (to second order in the swing, which is small
// here), and a whole period on they are back where they started.
import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { EXAMPLES, kanedyn, workDir } from '../support.js';
import { openPage, checkQuiet } from './check_page.js';

const dir = workDir('browser-mode');
const model = join(EXAMPLES, 'eight_body.yaml');
assert.equal(kanedyn(dir, 'equilibrium', model, '-o', 'rest.yaml').code, 0);
const lin = JSON.parse(kanedyn(dir, 'linearize', 'rest.yaml', '--json').out);
const [re, im] = lin.eigenvalues[0];
assert.ok(re < 0 && im > 0, `mode 1 of the figure at rest oscillates and decays: ${re} ${im}`);
const period = 2 * Math.PI / im;
// A swing of 0.02 (rad, or m for a slide): the second-order part of each displacement is a few
// per cent of it.
const amplitude = 0.02;
assert.equal(kanedyn(dir, 'view', 'rest.yaml', '--mode', '1', '--amplitude', `${amplitude}`, '-o', 'mode.html').code, 0);
assert.equal(kanedyn(dir, 'view', 'rest.yaml', '-o', 'rest.html').code, 0);

const restCtx = await openPage(join(dir, 'rest.html'));
const rest = await restCtx.page.evaluate(() => window.kanedynViewer.bodyPositions());
await restCtx.close();
const ctx = await openPage(join(dir, 'mode.html'));
after(() => ctx.close());

const at = (t) => ctx.page.evaluate((time) => { window.kanedynViewer.seek(time); return window.kanedynViewer.bodyPositions(); }, t);

test('the readout under the plot has values at load, before the mouse moves', async () => {
  const legend = await ctx.page.evaluate(() => window.kanedynViewer.legend(0));
  assert.equal(legend[0], 't0');
  assert.ok(legend.length >= 2 && !legend.some((l) => l.includes('--')), legend.join(' | '));
});

test('the page names the mode and its frequency', async () => {
  const text = await ctx.page.evaluate(() => document.body.textContent);
  assert.match(text, /mode 1 of 96 about its initial state: eigenvalue/);
  assert.match(text, new RegExp(`${(im / (2 * Math.PI)).toPrecision(4)} Hz`));
});

test('the bodies swing about the rest pose, half a period apart in opposite ways', async () => {
  const start = await at(0);
  const half = await at(period / 2);
  const d0 = [], d1 = [];
  for (let k = 0; k < rest.length; ++k) {
    for (const a of ['x', 'y', 'z']) {
      d0.push(start[k][a] - rest[k][a]);
      d1.push(half[k][a] - rest[k][a]);
    }
  }
  const largest = Math.max(...d0.map(Math.abs));
  assert.ok(largest > 1e-4, `the mode moves the bodies (largest displacement ${largest} m)`);
  // Opposite to first order: the sum is the second-order part, of the order of the swing times
  // the amplitude (measured: 0.06% of it); 1% is allowed.
  const worst = Math.max(...d0.map((d, i) => Math.abs(d + d1[i])));
  console.log(`largest displacement ${largest.toExponential(2)} m; largest d(0) + d(T/2) ${worst.toExponential(2)} m`);
  assert.ok(worst <= 0.01 * largest, `d(0) + d(T/2) up to ${worst} m against ${largest} m`);
});

test('a period on, the pose repeats', async () => {
  const start = await at(0);
  // The page interpolates rows linearly; one period is 120 rows of 240, so it lands on a row.
  const again = await at(period);
  for (let k = 0; k < start.length; ++k) {
    for (const a of ['x', 'y', 'z']) assert.ok(Math.abs(again[k][a] - start[k][a]) <= 1e-9);
  }
});

test('the plot shows the mode\'s coordinates, not the energy', async () => {
  const columns = await ctx.page.evaluate(() => window.kanedynViewer.plotColumns(0));
  assert.ok(columns.length >= 1 && columns.length <= 8, columns.join(', '));
  assert.ok(!columns.includes('energy'), columns.join(', '));
  // Named as kanedyn linearize names its state (NAME.r1, NAME.s2, NAME.j1), after "mode.".
  const names = new Set(lin.state);
  for (const c of columns) assert.ok(c.startsWith('mode.') && names.has(c.slice(5)), c);
  assert.equal(await ctx.page.$('#energy-plot'), null);
  // The largest coordinate swings by the amplitude: sampled at 120 rows a period, its peak
  // is within cos(pi / 120) (0.03%) of it; float32 storage adds 6e-8 relative.
  const peak = await ctx.page.evaluate((c) => Math.max(...window.kanedynViewer.column(c).map(Math.abs)), columns[0]);
  assert.ok(peak <= amplitude * (1 + 1e-6) && peak >= amplitude * 0.999, `largest swing ${peak} of ${amplitude}`);
});

test('no console error and no network request', () => {
  checkQuiet(ctx);
});
