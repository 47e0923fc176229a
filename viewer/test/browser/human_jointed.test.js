// The jointed human figure (revolute, universal and spherical joints) in headless chromium:
// its joint axes drawn where the page's data and motion put them, and the joints toggle.
import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { EXAMPLES, kanedyn, pageData, readCsv, workDir } from '../support.js';
import { openPage, checkPositions, checkScreenshot, checkQuiet } from './check_page.js';
import { decodePng } from './png.js';
import { decodeTrajectory } from '../../src/data.js';
import { createMotion } from '../../src/motion.js';
import { axisHalfLength, jointLines, lineSegments } from '../../src/joints.js';
import { fitView } from '../../src/fit.js';
import { JOINT_WIDTH } from '../../src/scene.js';

const dir = workDir('browser-human-jointed');
const model = join(EXAMPLES, 'human_jointed.yaml');
// 0.3 s: the figure falls 0.44 m, and stays large in the fitted view.
assert.equal(kanedyn(dir, 'simulate', model, '--t-end', '0.3', '-o', 'human.csv').code, 0);
assert.equal(kanedyn(dir, 'view', model, 'human.csv').code, 0);
const csv = readCsv(join(dir, 'human.csv'));
const data = pageData(join(dir, 'human.html'));
const ctx = await openPage(join(dir, 'human.html'));
after(() => ctx.close());

// The joint lines' colour (src/joints.js, JOINT_HEX.turn); lines are drawn unlit, in it.
const TURN = [0x6a, 0x0d, 0xc8];
const isTurn = ([r, g, b]) => Math.abs(r - TURN[0]) + Math.abs(g - TURN[1]) + Math.abs(b - TURN[2]) < 12;
const shot = async () => decodePng(await ctx.page.screenshot({ type: 'png' }));

test('the drawn mass centres are the CSV interpolated, between rows', async () => {
  const r = await checkPositions(ctx.page, csv, 0.1234);
  assert.equal(r.bodies, 8);
});

test('the joints toggle is there and on', async () => {
  assert.equal(await ctx.page.$eval('#joints', (e) => e.checked), true);
});

test('each joint axis is drawn through Q_K along the axis of the body it is fixed in', async () => {
  const t = 0.2345;
  const drawn = await ctx.page.evaluate((time) => { window.kanedynViewer.seek(time); return window.kanedynViewer.jointAxes(); }, t);
  const motion = createMotion(data.model, decodeTrajectory(data));
  const radius = fitView(data.model, motion).radius;
  const frame = motion.at(t);
  const lines = jointLines(data.model);
  // The pelvis's and the forearm's hinges, a1 and a2 of each hip.
  assert.deepEqual(drawn.map((j) => [j.name, j.type, j.in]), lines.map((l) => [l.name, l.type, l.in]));
  assert.equal(drawn.length, 6);
  let worst = 0;
  lines.forEach((l, i) => {
    const [[from, to]] = lineSegments(data.model, l, frame, axisHalfLength(data.model.bodies[l.body], radius));
    for (let a = 0; a < 3; ++a) {
      // The scene keeps them as float32: 6e-8 relative, of coordinates below 2 m.
      worst = Math.max(worst, Math.abs(drawn[i].from[a] - from[a]), Math.abs(drawn[i].to[a] - to[a]));
    }
  });
  assert.ok(worst < 1e-6, `largest difference from the axes computed here: ${worst} m`);
  // On the screen: the axis colour along every projected line (most of it: a body's own
  // lines, the links, may cross it).
  const img = await shot();
  for (const j of drawn) {
    let hits = 0;
    for (let s = 1; s <= 9; ++s) {
      const x0 = Math.round(j.pageFrom.x + (s / 10) * (j.pageTo.x - j.pageFrom.x));
      const y0 = Math.round(j.pageFrom.y + (s / 10) * (j.pageTo.y - j.pageFrom.y));
      let hit = false;
      for (let dy = -1; dy <= 1 && !hit; ++dy) for (let dx = -1; dx <= 1 && !hit; ++dx) hit = isTurn(img.rgb(x0 + dx, y0 + dy));
      if (hit) ++hits;
    }
    assert.ok(hits >= 6, `${j.name} (${j.in}): the axis colour at ${hits} of 9 points along it`);
  }
});

test('the joint axes are lines JOINT_WIDTH pixels wide', async () => {
  const drawn = await ctx.page.evaluate(() => { window.kanedynViewer.seek(0.2345); return window.kanedynViewer.jointAxes(); });
  const img = await shot();
  for (const j of drawn) {
    const dx = j.pageTo.x - j.pageFrom.x;
    const dy = j.pageTo.y - j.pageFrom.y;
    const len = Math.hypot(dx, dy);
    const nx = -dy / len;
    const ny = dx / len;
    // Across the line at seven points along it: the runs of the axis colour. Other lines cross
    // it at some (the pelvis's hinge crosses the hips' axes), so the median, not each.
    const runs = [];
    for (let s = 2; s <= 8; ++s) {
      const cx = j.pageFrom.x + (s / 10) * dx;
      const cy = j.pageFrom.y + (s / 10) * dy;
      let run = 0;
      for (let o = -6; o <= 6; o += 0.5) if (isTurn(img.rgb(Math.round(cx + o * nx), Math.round(cy + o * ny)))) run += 0.5;
      runs.push(run);
    }
    runs.sort((a, b) => a - b);
    // A line one device pixel wide (WebGL's own) reads as 1-1.5 here, JOINT_WIDTH = 3 as 2-3.5.
    assert.ok(runs[3] >= JOINT_WIDTH - 1, `${j.name} (${j.in}): ${runs[3]} px across (median of ${runs})`);
  }
});

test('the joints toggle off and on', async () => {
  const count = async () => {
    const img = await shot();
    let n = 0;
    for (let y = 0; y < img.height; ++y) for (let x = 0; x < img.width; ++x) if (isTurn(img.rgb(x, y))) ++n;
    return n;
  };
  const on = await count();
  await ctx.page.click('#joints');
  await ctx.page.evaluate(() => window.kanedynViewer.seek(window.kanedynViewer.time()));
  const off = await count();
  await ctx.page.click('#joints');
  await ctx.page.evaluate(() => window.kanedynViewer.seek(window.kanedynViewer.time()));
  const again = await count();
  console.log(`joint-coloured pixels: ${on} with the joints, ${off} without`);
  assert.ok(on > off + 100, `joint-coloured pixels: ${on} with the joints, ${off} without`);
  assert.equal(again, on);
});

test('the screenshot has the bodies where their mass centres project', async () => {
  await checkScreenshot(ctx.page, join(dir, 'human_jointed.png'));
});

test('no console error and no network request', () => {
  checkQuiet(ctx);
});
