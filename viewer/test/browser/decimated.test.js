// A trajectory of more than 20,000 rows (the tennis racket, 30 s at 1 ms: 30,001 rows): the
// page holds every 2nd row and says so.
import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { EXAMPLES, kanedyn, readCsv, workDir } from '../support.js';
import { openPage, checkPositions, checkQuiet } from './check_page.js';

const dir = workDir('browser-decimated');
const model = join(EXAMPLES, 'tennis_racket.yaml');
assert.equal(kanedyn(dir, 'simulate', model, '--t-end', '30', '--dt-out', '0.001', '-o', 'racket.csv').code, 0);
assert.equal(kanedyn(dir, 'view', model, 'racket.csv').code, 0);
const ctx = await openPage(join(dir, 'racket.html'));
after(() => ctx.close());

test('the page says it is decimated, and how', async () => {
  const note = await ctx.page.$eval('#decimated', (e) => e.textContent);
  assert.equal(note, 'Decimated: the trajectory has 30001 rows; this page holds every 2nd row and the last (15001 rows).');
  const v = await ctx.page.evaluate(() => ({ rows: window.kanedynViewer.rows, stride: window.kanedynViewer.stride }));
  assert.deepEqual(v, { rows: 15001, stride: 2 });
});

test('between kept rows it interpolates those rows', async () => {
  // Rows 2 ms apart are kept; the CSV with every 2nd row is what the page interpolates.
  const csv = readCsv(join(dir, 'racket.csv'));
  const kept = { header: csv.header, rows: csv.rows.filter((_, i) => i % 2 === 0) };
  await checkPositions(ctx.page, kept, 12.3451);
});

test('no console error and no network request', () => {
  checkQuiet(ctx);
});
