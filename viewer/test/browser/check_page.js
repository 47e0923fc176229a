// The checks every browser test makes on a page kanedyn view wrote (docs/viewer.md, "Tests").
import assert from 'node:assert/strict';
import { writeFileSync } from 'node:fs';
import { pathToFileURL } from 'node:url';
import { launch } from './browser.js';
import { decodePng } from './png.js';
import { interpolate } from '../support.js';

export const VIEWPORT = { width: 1000, height: 560, deviceScaleFactor: 1 };
// The scene's background, 0xf4f5f7 (src/scene.js): a pixel is "drawn" when a channel differs
// by more than this (anti-aliasing at an edge blends towards the background).
const BACKGROUND = [0xf4, 0xf5, 0xf7];
const DRAWN = 24;
const drawn = (p) => p.some((c, i) => Math.abs(c - BACKGROUND[i]) > DRAWN);

/** Opens the page; returns { page, close, errors, requests }. */
export async function openPage(htmlPath) {
  const { browser, close } = await launch();
  const page = await browser.newPage();
  await page.setViewport(VIEWPORT);
  const errors = [];
  const requests = [];
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(String(e)));
  page.on('requestfailed', (r) => errors.push(`request failed: ${r.url()}`));
  page.on('request', (r) => requests.push(r.url()));
  const url = pathToFileURL(htmlPath).href;
  await page.goto(url, { waitUntil: 'load' });
  await page.waitForFunction(() => window.kanedynViewer && window.kanedynViewer.ready, { timeout: 30000 });
  return { page, close, errors, requests, url };
}

/**
 * Seeks to t and checks the drawn mass centres against the CSV interpolated at t (1e-6 m:
 * the page holds G as float64 and interpolates linearly like the test, so the two differ by
 * round-off, ~1e-15 m; a row off or a wrong column is off by millimetres or more).
 */
export async function checkPositions(page, csv, t) {
  const got = await page.evaluate((time) => { window.kanedynViewer.seek(time); return window.kanedynViewer.bodyPositions(); }, t);
  let worst = 0;
  for (const b of got) {
    ['x', 'y', 'z'].forEach((a) => {
      const c = csv.header.indexOf(`${b.name}.${a}`);
      assert.ok(c > 0, `${b.name}.${a} in the CSV`);
      const want = interpolate(csv, c, t);
      const err = Math.abs(b[a] - want);
      worst = Math.max(worst, err);
      assert.ok(err <= 1e-6, `${b.name}.${a} at t = ${t}: drawn ${b[a]}, CSV ${want}`);
    });
  }
  return { bodies: got.length, worst };
}

/**
 * A screenshot at the current time: every projected mass centre has a drawn pixel within
 * 2 px (a body seen edge-on may be 2-3 px wide; its link segment through G is drawn too),
 * and the canvas's top-left corner, where no body is, is background (the check can fail).
 */
export async function checkScreenshot(page, savePath) {
  const png = await page.screenshot({ type: 'png' });
  if (savePath) writeFileSync(savePath, png);
  const img = decodePng(png);
  const centres = await page.evaluate(() => window.kanedynViewer.projectedCentres());
  const missing = [];
  for (const c of centres) {
    const x0 = Math.round(c.x);
    const y0 = Math.round(c.y);
    assert.ok(x0 >= 2 && y0 >= 2 && x0 < img.width - 2 && y0 < img.height - 2, `${c.name} projects into the view (${x0}, ${y0})`);
    let hit = false;
    for (let dy = -2; dy <= 2 && !hit; ++dy) for (let dx = -2; dx <= 2 && !hit; ++dx) hit = drawn(img.rgb(x0 + dx, y0 + dy));
    if (!hit) missing.push(`${c.name} at (${x0}, ${y0})`);
  }
  assert.deepEqual(missing, [], 'mass centres with no drawn pixel near them');
  assert.ok(!drawn(img.rgb(3, 3)), 'the corner of the scene is background');
  return { centres: centres.length, bytes: png.length };
}

/** The plot canvases have lines on them: more than 300 non-blank pixels each. */
export async function checkPlots(page) {
  const counts = await page.evaluate(() => window.kanedynViewer.plotCanvases().map((cv) => {
    const d = cv.getContext('2d').getImageData(0, 0, cv.width, cv.height).data;
    let n = 0;
    for (let i = 0; i < d.length; i += 4) if (d[i + 3] > 0 && !(d[i] > 250 && d[i + 1] > 250 && d[i + 2] > 250)) ++n;
    return n;
  }));
  assert.ok(counts.length >= 1, 'a plot');
  counts.forEach((n, i) => assert.ok(n > 300, `plot ${i} has ${n} drawn pixels`));
  return counts;
}

/**
 * Clicking the energy plot at time tc seeks there, to within one pixel's worth of time (the
 * click lands on a whole pixel).
 */
export async function checkPlotClick(page, tc) {
  await page.evaluate(() => window.kanedynViewer.seek(window.kanedynViewer.start));
  const p = await page.evaluate((time) => window.kanedynViewer.plotPoint(0, time), tc);
  await page.mouse.click(p.x, p.y);
  const { t, span, width } = await page.evaluate(() => ({
    t: window.kanedynViewer.time(),
    span: window.kanedynViewer.end - window.kanedynViewer.start,
    width: window.kanedynViewer.plotCanvases()[0].getBoundingClientRect().width,
  }));
  const pixel = span / (width - 80); // the plot area is narrower than the canvas
  assert.ok(Math.abs(t - tc) <= 1.5 * pixel, `clicked at t = ${tc}, the viewer is at t = ${t} (one pixel = ${pixel} s)`);
  return t;
}

/** Space plays and pauses; the right arrow steps to the next row. */
export async function checkKeys(page, csv) {
  await page.evaluate((t) => window.kanedynViewer.seek(t), csv.rows[1][0]);
  await page.keyboard.press('Space');
  assert.equal(await page.evaluate(() => window.kanedynViewer.playing()), true, 'space plays');
  await page.keyboard.press('Space');
  assert.equal(await page.evaluate(() => window.kanedynViewer.playing()), false, 'space pauses');
  // After a click on Play the button has the focus: space still pauses, once.
  await page.click('#play');
  assert.equal(await page.evaluate(() => window.kanedynViewer.playing()), true, 'the Play button plays');
  await page.keyboard.press('Space');
  assert.equal(await page.evaluate(() => window.kanedynViewer.playing()), false, 'space pauses after a click on Play');
  await page.evaluate((t) => window.kanedynViewer.seek(t), csv.rows[1][0]);
  await page.keyboard.press('ArrowRight');
  assert.equal(await page.evaluate(() => window.kanedynViewer.time()), csv.rows[2][0], 'right arrow: the next row');
  await page.keyboard.press('ArrowLeft');
  await page.keyboard.press('ArrowLeft');
  assert.equal(await page.evaluate(() => window.kanedynViewer.time()), csv.rows[0][0], 'left arrow twice: two rows back');
}

/** Picking a column from the list adds it to the plot of picked columns (one uPlot). */
export async function checkPicker(page, column) {
  const before = await page.$$eval('.chip', (els) => els.map((e) => e.textContent));
  await page.click('#picker');
  await page.keyboard.type(column);
  await page.keyboard.press('Enter');
  const n = await page.evaluate(() => window.kanedynViewer.plotCanvases().length);
  assert.equal(n, 2, `the energy plot and one of the picked columns, ${column} among them`);
  const chips = await page.$$eval('.chip', (els) => els.map((e) => e.textContent));
  assert.deepEqual(chips, [...before, `${column} \u00d7`]);
  assert.equal(await page.$eval('#picker', (e) => e.value), '', 'the list is ready for the next');
}

/**
 * Plays at 1x for `seconds` and returns the frame statistics (ms), how far the shown time
 * moved and how far the frames' own clock says it should have, and the renderer's resources
 * and the plot canvases before and after.
 */
export async function measureFrames(page, seconds) {
  return page.evaluate(async (s) => {
    const v = window.kanedynViewer;
    v.seek(v.start);
    v.setSpeed(1);
    const before = v.resources();
    const canvases = v.plotCanvases();
    v.clearFrameTimes();
    const stamps = [];
    const t0 = v.time();
    v.play();
    await new Promise((done) => {
      const start = performance.now();
      const tick = (now) => {
        stamps.push(now);
        if (now - start < s * 1000) requestAnimationFrame(tick);
        else done();
      };
      requestAnimationFrame(tick);
    });
    v.pause();
    const moved = v.time() - t0;
    const work = v.frameTimes().sort((a, b) => a - b);
    const gaps = stamps.slice(1).map((x, i) => x - stamps[i]);
    // The page advances by each frame's interval, at most 0.25 s of it (main.js).
    const clock = gaps.reduce((sum, g) => sum + Math.min(g, 250), 0) / 1000;
    const largestGap = Math.max(...gaps);
    gaps.sort((a, b) => a - b);
    const q = (a, f) => a[Math.min(a.length - 1, Math.floor(f * a.length))];
    const after = v.plotCanvases();
    return {
      frames: work.length,
      software: v.softwareRendering,
      workMedian: q(work, 0.5),
      workP95: q(work, 0.95),
      intervalMedian: q(gaps, 0.5),
      intervalP95: q(gaps, 0.95),
      largestGap,
      moved,
      clock,
      before,
      after: v.resources(),
      samePlots: canvases.length === after.length && canvases.every((c, i) => c === after[i]),
    };
  }, seconds);
}

/** No console error, and no request but the page itself. */
export function checkQuiet(ctx) {
  assert.deepEqual(ctx.errors, [], 'console errors');
  assert.deepEqual(ctx.requests, [ctx.url], 'requests beyond the page itself');
}

/** Hovering over a body's mass centre shows its name. */
export async function checkHover(page, k, name) {
  const c = (await page.evaluate(() => window.kanedynViewer.projectedCentres()))[k];
  await page.mouse.move(c.x, c.y);
  const tip = await page.$eval('.tip', (e) => ({ hidden: e.hidden, text: e.textContent }));
  assert.deepEqual(tip, { hidden: false, text: `${k + 1} ${name}` });
  await page.mouse.move(2, 2);
  assert.equal(await page.$eval('.tip', (e) => e.hidden), true, 'no name over the background');
}

/**
 * Following body k keeps its mass centre where it is on the page (to 0.5 px) while time
 * moves it; without following it moves.
 */
export async function checkFollow(page, k, t0, t1) {
  const at = (t) => page.evaluate((time, i) => { window.kanedynViewer.seek(time); return window.kanedynViewer.projectedCentres()[i]; }, t, k);
  const a = await at(t0);
  const b = await at(t1);
  const moved = Math.hypot(b.x - a.x, b.y - a.y);
  assert.ok(moved > 3, `body ${k + 1} moves ${moved} px on the page between t = ${t0} and ${t1}`);
  await at(t0);
  await page.select('#follow', String(k));
  const c = await at(t0);
  const d = await at(t1);
  assert.ok(Math.hypot(d.x - c.x, d.y - c.y) < 0.5, `followed, body ${k + 1} moves from (${c.x}, ${c.y}) to (${d.x}, ${d.y})`);
  await page.select('#follow', '-1');
}

// The axes' colours (src/scene.js, AXIS_HEX); lines are drawn unlit, in exactly these.
const AXIS_RGB = [[0xd0, 0x20, 0x20], [0x10, 0x90, 0x10], [0x20, 0x40, 0xe0]];

/** "body axes" draws each body's axes: many more pixels of the axes' colours. */
export async function checkAxes(page) {
  const count = async () => {
    const img = decodePng(await page.screenshot({ type: 'png' }));
    let n = 0;
    for (let y = 0; y < img.height; ++y) {
      for (let x = 0; x < img.width; ++x) {
        const [r, g, b] = img.rgb(x, y);
        if (AXIS_RGB.some((c) => Math.abs(r - c[0]) + Math.abs(g - c[1]) + Math.abs(b - c[2]) < 12)) ++n;
      }
    }
    return n;
  };
  const before = await count();
  await page.click('#axes');
  await page.evaluate(() => window.kanedynViewer.seek(window.kanedynViewer.time()));
  const after = await count();
  await page.click('#axes');
  assert.ok(after > before + 100, `axis-coloured pixels: ${before} without the axes, ${after} with them`);
  return { before, after };
}
