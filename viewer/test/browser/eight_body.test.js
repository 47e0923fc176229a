// The eight-body example's 10 s page in headless chromium.
import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { EXAMPLES, SOURCE, kanedyn, readCsv, workDir } from '../support.js';
import {
  openPage, checkPositions, checkScreenshot, checkPlots, checkPlotClick, checkKeys, checkPicker, checkQuiet, checkHover, checkFollow, checkAxes,
} from './check_page.js';

const dir = workDir('browser-eight-body');
const model = join(EXAMPLES, 'eight_body.yaml');
assert.equal(kanedyn(dir, 'simulate', model, '-o', 'eight_body.csv').code, 0);
assert.equal(kanedyn(dir, 'view', model, 'eight_body.csv').code, 0);
const csv = readCsv(join(dir, 'eight_body.csv'));
const ctx = await openPage(join(dir, 'eight_body.html'));
after(() => ctx.close());

test('the drawn mass centres are the CSV interpolated, between rows', async () => {
  // 2.3437 s lies 37% of the way from the row at 2.34 s to the one at 2.35 s.
  const r = await checkPositions(ctx.page, csv, 2.3437);
  assert.equal(r.bodies, 8);
  console.log(`largest difference from the CSV: ${r.worst.toExponential(2)} m`);
});

test('the screenshot has the bodies where their mass centres project', async () => {
  // With a picked column plotted, for the README's picture.
  await ctx.page.evaluate(() => { window.kanedynViewer.pick('torso.w2'); window.kanedynViewer.seek(2.3437); });
  await checkScreenshot(ctx.page, join(SOURCE, 'docs/viewer-eight-body.png'));
});

test('the plots are drawn, and clicking one seeks', async () => {
  await checkPlots(ctx.page);
  await checkPlotClick(ctx.page, 6.5);
});

test('keyboard and column picker', async () => {
  await checkKeys(ctx.page, csv);
  await checkPicker(ctx.page, 'pelvis.z');
  await checkPlots(ctx.page);
});

test('names on hover, and following a body', async () => {
  await checkHover(ctx.page, 0, 'torso');
  // The torso sways forward and back over the first seconds.
  await checkFollow(ctx.page, 0, 0, 1.0);
});

test('the body axes toggle on and off; no joints toggle for free bodies', async () => {
  assert.equal(await ctx.page.$('#joints'), null);
  const r = await checkAxes(ctx.page);
  console.log(`axis-coloured pixels: ${r.before} without the axes, ${r.after} with them`);
});

test('no console error and no network request', () => {
  checkQuiet(ctx);
});
