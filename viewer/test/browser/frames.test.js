// The model's frames, the links only where something joins a body to its lower body, and the
// grid on the ground plane. The six-joint arm (examples/urdf/arm.urdf) has one frame, its tool
// flange (a massless link on a fixed joint), drawn as small RGB axes fixed in wrist_3_link while
// the arm falls for 0.5 s. The tennis racket (a free body with nothing between it and the
// ground) has no line from the origin; the 64-link chain hangs below the grid at z = 0.
import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { pathToFileURL } from 'node:url';
import { EXAMPLES, SOURCE, interpolate, kanedyn, pageData, readCsv, workDir } from '../support.js';
import { openPage, checkQuiet } from './check_page.js';
import { decodePng } from './png.js';

const dir = workDir('browser-frames');
const arm = join(EXAMPLES, 'urdf/arm.urdf');
assert.equal(kanedyn(dir, 'simulate', arm, '--t-end', '0.5', '-o', 'arm.csv').code, 0);
assert.equal(kanedyn(dir, 'view', arm, 'arm.csv', '--trace', 'tool_flange', '-o', 'arm.html').code, 0);
// The frame as the URDF import writes it (not the page's own data).
const imported = kanedyn(dir, 'import', arm, '-o', '-').out;
const m = imported.match(/- name: "tool_flange".*\n\s+body: "(\w+)"\n\s+at: \[(.*)\]\n\s+rotation: \{axis: \[(.*)\], angle: (.*)\}/);
assert.ok(m, 'the import writes the tool flange as a frame');
const FRAME = { body: m[1], at: m[2].split(',').map(Number), axis: m[3].split(',').map(Number), angle: Number(m[4]) };
const csv = readCsv(join(dir, 'arm.csv'));
const data = pageData(join(dir, 'arm.html'));
const ctx = await openPage(join(dir, 'arm.html'));
after(() => ctx.close());

/** Another page in the same browser (no second start of chromium): its page, errors and close. */
async function openAlso(html) {
  const page = await ctx.page.browser().newPage();
  await page.setViewport(ctx.page.viewport());
  const errors = [];
  page.on('console', (msg) => { if (msg.type() === 'error') errors.push(msg.text()); });
  page.on('pageerror', (err) => errors.push(String(err)));
  await page.goto(pathToFileURL(html).href, { waitUntil: 'load' });
  await page.waitForFunction(() => window.kanedynViewer && window.kanedynViewer.ready, { timeout: 30000 });
  return { page, errors, close: () => page.close() };
}

/** v turned by the unit quaternion q = (x, y, z, w): v + 2w (q x v) + 2 q x (q x v). */
function rotate(q, v) {
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const u = q.slice(0, 3);
  const c = cross(u, v);
  const cc = cross(u, c);
  return v.map((x, i) => x + 2 * q[3] * c[i] + 2 * cc[i]);
}
const AXIS_RGB = [[0xd0, 0x20, 0x20], [0x10, 0x90, 0x10], [0x20, 0x40, 0xe0]];

test('the frame is drawn at its body\'s point, its axes turned as the model says', async () => {
  const t = 0.3456;
  const got = (await ctx.page.evaluate((time) => { window.kanedynViewer.seek(time); return window.kanedynViewer.frames(); }, t));
  assert.equal(got.length, 1);
  assert.equal(got[0].name, 'tool_flange');
  const k = data.model.bodies.findIndex((b) => b.name === FRAME.body);
  assert.equal(got[0].body, k);
  // The body's pose from the CSV, between rows: G interpolated, the Euler parameters
  // interpolated and normalized (rows 0.01 s apart: within 1e-6 of the page's slerp).
  const col = (s) => csv.header.indexOf(`${FRAME.body}.${s}`);
  const g = ['x', 'y', 'z'].map((s) => interpolate(csv, col(s), t));
  const e = ['e1', 'e2', 'e3', 'e4'].map((s) => interpolate(csv, col(s), t));
  const n = Math.hypot(...e);
  const q = e.map((x) => x / n); // body -> inertial
  const o = g.map((x, i) => x - rotate(q, data.model.bodies[k].com)[i]);
  const origin = o.map((x, i) => x + rotate(q, FRAME.at)[i]);
  got[0].origin.forEach((x, i) => assert.ok(Math.abs(x - origin[i]) < 1e-5, `origin ${i}: ${x} vs ${origin[i]}`));
  // The frame's axes: body K's turned by `angle` about `axis`.
  const s = Math.sin(FRAME.angle / 2);
  const r = [...FRAME.axis.map((a) => a * s), Math.cos(FRAME.angle / 2)];
  [[1, 0, 0], [0, 1, 0], [0, 0, 1]].forEach((unit, a) => {
    const dir = rotate(q, rotate(r, unit));
    const tip = got[0].tips[a];
    dir.forEach((d, i) => {
      const drawn = (tip[i] - got[0].origin[i]) / got[0].length;
      assert.ok(Math.abs(drawn - d) < 1e-5, `axis ${a}[${i}]: ${drawn} vs ${d}`);
    });
  });
});

test('the frame\'s axes are on the screen in red, green and blue, and go with the toggle', async () => {
  const t = 0.25;
  const probe = async () => {
    const f = (await ctx.page.evaluate((time) => { window.kanedynViewer.seek(time); return window.kanedynViewer.frames(); }, t))[0];
    const img = decodePng(await ctx.page.screenshot({ type: 'png' }));
    // Two-thirds of the way along each axis on the page, its colour within 2 px.
    return f.pageTips.map((tip, a) => {
      const x0 = Math.round(f.pageOrigin.x + (2 / 3) * (tip.x - f.pageOrigin.x));
      const y0 = Math.round(f.pageOrigin.y + (2 / 3) * (tip.y - f.pageOrigin.y));
      let hit = false;
      for (let dy = -2; dy <= 2; ++dy) {
        for (let dx = -2; dx <= 2; ++dx) {
          const [r, g, b] = img.rgb(x0 + dx, y0 + dy);
          const c = AXIS_RGB[a];
          if (Math.abs(r - c[0]) + Math.abs(g - c[1]) + Math.abs(b - c[2]) < 12) hit = true;
        }
      }
      return hit;
    });
  };
  assert.equal(await ctx.page.$eval('#frames', (e) => e.checked), true);
  assert.deepEqual(await probe(), [true, true, true]);
  await ctx.page.click('#frames');
  assert.deepEqual(await probe(), [false, false, false]);
  await ctx.page.click('#frames');
});

test('the frame\'s path is traced', async () => {
  assert.deepEqual(await ctx.page.evaluate(() => window.kanedynViewer.traces()), ['tool_flange']);
  const path = await ctx.page.evaluate(() => { window.kanedynViewer.seek(window.kanedynViewer.end); return window.kanedynViewer.drawnTrace('tool_flange'); });
  const f = (await ctx.page.evaluate(() => window.kanedynViewer.frames()))[0];
  assert.equal(path.length, csv.rows.length);
  path[path.length - 1].forEach((x, i) => assert.ok(Math.abs(x - f.origin[i]) < 1e-5, 'the trace ends at the frame'));
  const travel = Math.hypot(...path[0].map((x, i) => x - path[path.length - 1][i]));
  assert.ok(travel > 0.05, `the flange moves ${travel} m`);
});

test('links only where a joint or a bushing joins a body to the one below', async () => {
  // The arm: every body on a joint.
  assert.equal(await ctx.page.evaluate(() => window.kanedynViewer.linkCount), 8);
  assert.ok(data.model.bodies.every((b) => b.linked === true));
  for (const [file, count] of [['tennis_racket.yaml', 0], ['eight_body.yaml', 8], ['satellite.yaml', 2]]) {
    const name = file.replace('.yaml', '.html');
    assert.equal(kanedyn(dir, 'view', join(EXAMPLES, file), '-o', name).code, 0);
    assert.equal(pageData(join(dir, name)).model.bodies.filter((b) => b.linked).length, count, file);
  }
  // The racket's page draws no link at all.
  const racket = await openAlso(join(dir, 'tennis_racket.html'));
  try {
    assert.equal(await racket.page.evaluate(() => window.kanedynViewer.linkCount), 0);
    assert.deepEqual(racket.errors, []);
  } finally {
    await racket.close();
  }
});

test('the grid lies on the ground plane through the origin, or below the motion without gravity', async () => {
  assert.equal(kanedyn(dir, 'view', join(EXAMPLES, 'chain64.yaml'), '-o', 'chain.html').code, 0);
  const chain = await openAlso(join(dir, 'chain.html'));
  try {
    const { ground, lowest } = await chain.page.evaluate(() => ({
      ground: window.kanedynViewer.ground(),
      lowest: Math.min(...window.kanedynViewer.bodyPositions().map((p) => p.z)),
    }));
    // Gravity along -z: the plane z = 0, though the chain hangs below it.
    assert.equal(ground[2], 0);
    assert.ok(lowest < -1, `the chain hangs below it (${lowest} m)`);
  } finally {
    await chain.close();
  }
  const racket = await openAlso(join(dir, 'tennis_racket.html'));
  try {
    const { ground, lowest } = await racket.page.evaluate(() => ({
      ground: window.kanedynViewer.ground(),
      lowest: Math.min(...window.kanedynViewer.bodyPositions().map((p) => p.z)),
    }));
    // No gravity: below the racket (its mass centre at the origin), by at least its size.
    assert.ok(ground[2] < lowest - 0.05, `grid at z = ${ground[2]}, racket at ${lowest}`);
  } finally {
    await racket.close();
  }
});

test('a screenshot of the arm with its tool frame and the frame\'s path', async () => {
  // Following the wrist, zoomed in by the mouse wheel (6 notches) towards it.
  await ctx.page.evaluate((k) => { window.kanedynViewer.follow(k); window.kanedynViewer.seek(0.45); }, data.model.bodies.findIndex((b) => b.name === FRAME.body));
  await ctx.page.mouse.move(300, 250);
  for (let i = 0; i < 6; ++i) await ctx.page.mouse.wheel({ deltaY: -100 });
  await ctx.page.mouse.move(2, 2); // no name shown on hover
  await ctx.page.evaluate(() => window.kanedynViewer.seek(0.45));
  const png = await ctx.page.screenshot({ type: 'png', path: join(SOURCE, 'docs/viewer-arm-frames.png') });
  assert.ok(png.length < 150000, `${png.length} bytes`);
  await ctx.page.evaluate(() => window.kanedynViewer.follow(-1));
});

test('no console error and no network request', () => {
  checkQuiet(ctx);
});
