// `kanedyn view` on the command line: what the page holds, its name, the errors, the
// .partial rule and decimation. (How long a page takes is measured by hand, docs/cli.md: a
// timed test fails on a loaded machine and proves nothing on a fast one.)
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync, readdirSync, readFileSync, writeFileSync, mkdirSync, symlinkSync } from 'node:fs';
import { join } from 'node:path';
import { EXAMPLES, kanedyn, pageData, readCsv, workDir } from '../support.js';
import { decodeTrajectory } from '../../src/data.js';
import { createMotion } from '../../src/motion.js';
import { rotationMatrix } from '../../src/interp.js';
import { jointLines, lineSegments } from '../../src/joints.js';
import { discContact } from '../../src/constraints.js';
import { fitView } from '../../src/fit.js';

const dir = workDir('cli');
const eight = join(EXAMPLES, 'eight_body.yaml');
const chain = join(EXAMPLES, 'chain64.yaml');
const racket = join(EXAMPLES, 'tennis_racket.yaml');
const human = join(EXAMPLES, 'human_jointed.yaml');
const cart = join(EXAMPLES, 'cart_pendulum.yaml');

const sim = kanedyn(dir, 'simulate', eight, '-o', 'eight.csv');
assert.equal(sim.code, 0, sim.err);

test('the eight-body 10 s page holds every row: t and G exactly, the rest as float32', () => {
  const r = kanedyn(dir, 'view', eight, 'eight.csv');
  assert.equal(r.code, 0, r.err);
  assert.match(r.out, /^wrote eight\.html \([0-9.]+ kB; 1001 rows\)\n$/);
  const d = pageData(join(dir, 'eight.html'));
  const csv = readCsv(join(dir, 'eight.csv'));
  assert.deepEqual(d.columns, csv.header);
  assert.equal(d.rows, 1001);
  assert.equal(d.stride, 1);
  const traj = decodeTrajectory(d);
  for (let c = 0; c < csv.header.length; ++c) {
    const wide = d.f64_columns.includes(c);
    for (let i = 0; i < csv.rows.length; i += 7) {
      const want = wide ? csv.rows[i][c] : Math.fround(csv.rows[i][c]);
      assert.equal(traj.columns[c][i], want, `${csv.header[c]}, row ${i}`);
    }
  }
  for (const name of ['t', 'torso.x', 'pelvis.y', `${d.model.bodies[7].name}.z`, 'energy']) assert.ok(d.f64_columns.includes(d.columns.indexOf(name)), name);
  assert.equal(d.model.bodies.length, 8);
  assert.equal(d.model.bodies[1].L, 0); // pelvis on torso
  assert.equal(d.model.bodies[0].inertia.length, 9);
  assert.deepEqual(d.model.bodies[0].joint, [0, 0, 1]); // the waist, examples/eight_body.yaml
  assert.deepEqual(d.model.bodies[2].joint, [0, -0.09, -0.12]); // right hip, in pelvis axes
  assert.deepEqual(d.model.gravity, [0, 0, -9.81]);
});

test("a jointed model's page has each body's joint type and axes", () => {
  // examples/human_jointed.yaml: the axes as written there, in J for the hinges and a1, in K
  // for a universal joint's a2 (at zero angles K's axes are F's, here J's).
  let r = kanedyn(dir, 'view', human, '-o', 'human.html');
  assert.equal(r.code, 0, r.err);
  const y = { axis: [0, 1, 0], in: 'parent', turn: true, slide: false };
  const hip = [
    { axis: [0, 1, 0], in: 'parent', turn: true, slide: false },
    { axis: [1, 0, 0], in: 'body', turn: true, slide: false },
  ];
  const joints = (d) => d.model.bodies.map((b) => [b.name, b.joint_type, b.joint_axes]);
  assert.deepEqual(joints(pageData(join(dir, 'human.html'))), [
    ['torso', 'free', []],
    ['pelvis', 'revolute', [y]],
    ['right_leg', 'universal', hip],
    ['left_leg', 'universal', hip],
    ['head', 'spherical', []],
    ['right_arm', 'spherical', []],
    ['left_upper_arm', 'spherical', []],
    ['left_forearm', 'revolute', [y]],
  ]);
  r = kanedyn(dir, 'view', cart, '-o', 'cart.html');
  assert.equal(r.code, 0, r.err);
  const d = pageData(join(dir, 'cart.html'));
  assert.deepEqual(joints(d), [
    ['cart', 'prismatic', [{ axis: [1, 0, 0], in: 'parent', turn: false, slide: true }]],
    ['pendulum', 'revolute', [y]],
  ]);
  // The joint point the axes pass through: Q_K, q'_K in J (the origin, for both).
  assert.deepEqual(d.model.bodies.map((b) => [b.L, b.joint]), [[-1, [0, 0, 0]], [0, [0, 0, 0]]]);
  // A model of free bodies has neither key.
  const eightBody = pageData(join(dir, 'eight.html')).model.bodies[0];
  assert.ok(!('joint_type' in eightBody) && !('joint_axes' in eightBody));
});

test("a jointed model's page draws its axes from its trajectory", () => {
  const r = kanedyn(dir, 'simulate', cart, '--t-end', '1', '-o', 'cart.csv');
  assert.equal(r.code, 0, r.err);
  assert.equal(kanedyn(dir, 'view', cart, 'cart.csv').code, 0);
  const d = pageData(join(dir, 'cart.html'));
  const frame = createMotion(d.model, decodeTrajectory(d)).at(1);
  const [rail, hinge] = jointLines(d.model);
  // The rail is the inertial x axis through the origin; the hinge turns with the cart and
  // passes through O_cart, where the cart has slid to (cart.q1 in the CSV, x of G).
  const csv = readCsv(join(dir, 'cart.csv'));
  const last = csv.rows[csv.rows.length - 1];
  const [[from, to]] = lineSegments(d.model, rail, frame, 0.1);
  assert.deepEqual([from, to], [[-0.1, 0, 0], [0.1, 0, 0]]);
  const [[a, b]] = lineSegments(d.model, hinge, frame, 0.1);
  const x = last[csv.header.indexOf('cart.x')];
  for (const [p, s] of [[a, -1], [b, 1]]) {
    assert.ok(Math.abs(p[0] - x) < 1e-6 && Math.abs(p[2]) < 1e-6, `hinge end ${p}`);
    assert.ok(Math.abs(p[1] - s * 0.1) < 1e-6, `hinge end ${p} along y`);
  }
});

test('the page is self-contained: no external script, style, link or frame', () => {
  const html = readFileSync(join(dir, 'eight.html'), 'utf8');
  assert.doesNotMatch(html, /<script[^>]*\ssrc=/i);
  assert.doesNotMatch(html, /<link[\s>]/i);
  assert.doesNotMatch(html, /<(iframe|img)[\s>]/i);
  assert.doesNotMatch(html, /@import/i);
  assert.match(html, /Content-Security-Policy" content="default-src 'none'/);
});

test('without a trajectory: the initial state, equal to kanedyn inspect', () => {
  const r = kanedyn(dir, 'view', eight);
  assert.equal(r.code, 0, r.err);
  assert.match(r.out, /^wrote eight_body\.html \([0-9.]+ kB; the initial state\)\n$/);
  const d = pageData(join(dir, 'eight_body.html'));
  assert.equal(d.rows, 1);
  assert.equal(d.source, 'initial state');
  const ins = JSON.parse(kanedyn(dir, 'inspect', eight, '--json', '--quantity', 'R', '--quantity', 'p_O', '--quantity', 'p_G').out);
  const motion = createMotion(d.model, decodeTrajectory(d));
  const frame = motion.at(0);
  ins.bodies.forEach((b, k) => {
    // G is stored as float64: the tool's own numbers.
    assert.deepEqual(frame[k].g, b.p_G, `${b.name} G`);
    // eps as float32 (relative 6e-8): [R] and O_K = G_K - R^T r'_K to 1e-6.
    const R = rotationMatrix(frame[k].e);
    for (let i = 0; i < 9; ++i) assert.ok(Math.abs(R[i] - b.R[Math.floor(i / 3)][i % 3]) < 1e-6, `${b.name} R[${i}]`);
    for (let a = 0; a < 3; ++a) assert.ok(Math.abs(frame[k].o[a] - b.p_O[a]) < 1e-6, `${b.name} O[${a}]: ${frame[k].o[a]} vs ${b.p_O[a]}`);
  });
});

test("a trajectory of another model: a clear error, and no page", () => {
  const r = kanedyn(dir, 'view', chain, 'eight.csv', '-o', 'wrong.html');
  assert.equal(r.code, 1);
  assert.equal(r.err, "kanedyn: error: eight.csv:1: column 2 is 'torso.x' where this model's trajectory has 'link1.x': the trajectory is not of 'chain of 64 links'\n");
  assert.ok(!existsSync(join(dir, 'wrong.html')) && !existsSync(join(dir, 'wrong.html.partial')));
});

test('a damaged row or time going backwards names the line', () => {
  const lines = readFileSync(join(dir, 'eight.csv'), 'utf8').split('\n');
  const bad = [...lines];
  bad[4] = bad[4].replace(/,[^,]*$/, ',abc');
  writeFileSync(join(dir, 'bad.csv'), bad.join('\n'));
  let r = kanedyn(dir, 'view', eight, 'bad.csv');
  assert.equal(r.code, 1);
  assert.equal(r.err, "kanedyn: error: bad.csv:5: column 'energy': 'abc' is not a finite number\n");
  const back = [...lines];
  [back[3], back[4]] = [back[4], back[3]];
  writeFileSync(join(dir, 'back.csv'), back.join('\n'));
  r = kanedyn(dir, 'view', eight, 'back.csv');
  assert.equal(r.code, 1);
  assert.equal(r.err, 'kanedyn: error: back.csv:5: t = 0.02 is before the previous row\'s t = 0.03\n');
  assert.ok(!existsSync(join(dir, 'bad.html')) && !existsSync(join(dir, 'back.html')));
});

test('the .partial rule: a failed write leaves no page, a good one no partial file', () => {
  let r = kanedyn(dir, 'view', eight, 'eight.csv', '-o', 'nofolder/x.html');
  assert.equal(r.code, 1);
  assert.match(r.err, /its folder 'nofolder' does not exist/);
  mkdirSync(join(dir, 'adir'), { recursive: true });
  r = kanedyn(dir, 'view', eight, 'eight.csv', '-o', 'adir');
  assert.equal(r.code, 1);
  assert.match(r.err, /is a directory/);
  r = kanedyn(dir, 'view', eight, 'eight.csv', '-o', 'eight.csv');
  assert.equal(r.code, 1);
  assert.match(r.err, /is the input file/);
  assert.equal(readCsv(join(dir, 'eight.csv')).rows.length, 1001);
  // An existing page is replaced whole, by the rename.
  writeFileSync(join(dir, 'keep.html'), 'old');
  r = kanedyn(dir, 'view', eight, 'eight.csv', '-o', 'keep.html');
  assert.equal(r.code, 0, r.err);
  assert.ok(readFileSync(join(dir, 'keep.html'), 'utf8').startsWith('<!DOCTYPE html>'));
  assert.deepEqual(readdirSync(dir).filter((f) => f.endsWith('.partial')), []);
});

test('a model name with </script> in it stays data', () => {
  const text = readFileSync(racket, 'utf8').replace(/^name: .*$/m, 'name: "a </script><b>x</b>"');
  writeFileSync(join(dir, 'odd_name.yaml'), text);
  const r = kanedyn(dir, 'view', 'odd_name.yaml');
  assert.equal(r.code, 0, r.err);
  assert.equal(pageData(join(dir, 'odd_name.html')).model.name, 'a </script><b>x</b>');
});

test('a partial file that is a link is not written through', () => {
  writeFileSync(join(dir, 'target.txt'), 'keep');
  symlinkSync('target.txt', join(dir, 'linked.html.partial'));
  const r = kanedyn(dir, 'view', eight, 'eight.csv', '-o', 'linked.html');
  assert.equal(r.code, 1);
  assert.equal(r.err, "kanedyn: error: cannot create 'linked.html.partial': it exists and is a symbolic link; remove it, or choose another output\n");
  assert.equal(readFileSync(join(dir, 'target.txt'), 'utf8'), 'keep');
  assert.ok(!existsSync(join(dir, 'linked.html')));
});

test('more than 20,000 rows: every k-th row and the last, and the page says how many', () => {
  const r = kanedyn(dir, 'simulate', racket, '--t-end', '30', '--dt-out', '0.001', '-o', 'long.csv');
  assert.equal(r.code, 0, r.err);
  const csv = readCsv(join(dir, 'long.csv'));
  assert.equal(csv.rows.length, 30001);
  const check = (file, rowsInFile, stride, kept) => {
    const v = kanedyn(dir, 'view', racket, file);
    assert.equal(v.code, 0, v.err);
    assert.match(v.out, new RegExp(`${rowsInFile} rows, decimated to 1 row in ${stride}\\)`));
    const d = pageData(join(dir, file.replace('.csv', '.html')));
    assert.equal(d.rows_in_file, rowsInFile);
    assert.equal(d.stride, stride);
    assert.equal(d.rows, kept);
    const t = decodeTrajectory(d).columns[0];
    for (let i = 0; i + 1 < kept; ++i) assert.equal(t[i], csv.rows[i * stride][0]);
    assert.equal(t[kept - 1], csv.rows[rowsInFile - 1][0]); // ends where the run ends
  };
  check('long.csv', 30001, 2, 15001); // row 30000 is a 2nd row already
  const lines = readFileSync(join(dir, 'long.csv'), 'utf8').split('\n').filter((l) => l);
  writeFileSync(join(dir, 'odd.csv'), lines.slice(0, -1).join('\n') + '\n');
  check('odd.csv', 30000, 2, 15001); // 0, 2, ..., 29998 and the last, 29999
  writeFileSync(join(dir, 'edge.csv'), lines.slice(0, 20001).join('\n') + '\n');
  const v = kanedyn(dir, 'view', racket, 'edge.csv');
  assert.equal(v.code, 0, v.err);
  assert.equal(pageData(join(dir, 'edge.html')).stride, 1); // 20,000 rows: all kept
});

test('the constraints: as the model gives them, and the contact points where the tool puts them', () => {
  const bicycle = join(EXAMPLES, 'bicycle.yaml');
  assert.equal(kanedyn(dir, 'simulate', bicycle, '--t-end', '0.6', '-o', 'bicycle.csv').code, 0);
  assert.equal(kanedyn(dir, 'view', bicycle, 'bicycle.csv').code, 0);
  const d = pageData(join(dir, 'bicycle.html'));
  assert.deepEqual(d.model.constraints, [
    { name: 'rear_contact', type: 'rolling_disc', body: 1, at: [0, 0, 0], axis: [0, 1, 0], radius: 0.3, plane_normal: [0, 0, 1], plane_offset: 0 },
    { name: 'front_contact', type: 'rolling_disc', body: 3, at: [0, 0, 0], axis: [0, 1, 0], radius: 0.35, plane_normal: [0, 0, 1], plane_offset: 0 },
  ]);
  // At 0.5 s (a row) the bicycle leans and steers: the contact points the page computes from
  // its own data are the ones kanedyn inspect reports, to 1e-6 m (the page's Euler
  // parameters are float32, relative step 6e-8, on wheels of 0.35 m).
  const ins = JSON.parse(kanedyn(dir, 'inspect', bicycle, '--json', '--trajectory', 'bicycle.csv', '--t', '0.5').out);
  const motion = createMotion(d.model, decodeTrajectory(d));
  const frame = motion.at(0.5);
  d.model.constraints.forEach((c, i) => {
    const want = ins.constraints.reactions[i];
    assert.equal(want.name, c.name);
    const got = discContact(c, frame).contact;
    for (let a = 0; a < 3; ++a) assert.ok(Math.abs(got[a] - want.point[a]) < 1e-6, `${c.name} P[${a}]: ${got[a]} vs ${want.point[a]}`);
  });
  // The rear frame leans by more than 1e-3 rad there: the contact is not just under the centre.
  const lean = Math.abs(frame[1].g[1] - discContact(d.model.constraints[0], frame).contact[1]);
  assert.ok(lean > 1e-4, `the rear contact is ${lean} m aside from the wheel's centre`);
  // The grid lies in the wheels' plane z = 0.
  assert.equal(fitView(d.model, motion).ground[2], 0);

  const fourBar = join(EXAMPLES, 'four_bar.yaml');
  assert.equal(kanedyn(dir, 'view', fourBar, '-o', 'four_bar.html').code, 0);
  const f = pageData(join(dir, 'four_bar.html'));
  assert.deepEqual(f.model.constraints, [
    { name: 'closure', type: 'hinge', body: 2, at: [0.9, 0, 0], axis: [0, 0, 1], other: -1, other_at: [1, 0, 0], other_axis: [0, 0, 1] },
  ]);
  // The initial state's page holds the page's own columns, not the run's reactions.
  assert.deepEqual(f.columns.slice(-2), ['rocker.sd3', 'energy']);
  // A mode of the bicycle: a page too.
  const mode = kanedyn(dir, 'view', bicycle, '--mode', '3', '-o', 'bicycle_mode.html');
  assert.equal(mode.code, 0, mode.err);
  assert.equal(pageData(join(dir, 'bicycle_mode.html')).model.constraints.length, 2);
  // A model without constraints has no such key.
  assert.equal(pageData(join(dir, 'eight.html')).model.constraints, undefined);
});
