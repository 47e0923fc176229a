// What the CLI and browser tests share: where things are, running the tool, reading a
// trajectory CSV and the data a page holds.
import { spawnSync } from 'node:child_process';
import { mkdirSync, readFileSync, rmSync } from 'node:fs';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
export const SOURCE = process.env.KANEDYN_SOURCE_DIR || resolve(here, '../..');
export const TOOL = process.env.KANEDYN_TOOL || join(SOURCE, 'build/kanedyn');
export const EXAMPLES = join(SOURCE, 'examples');

/** A fresh folder for one test file, under KANEDYN_WORK_DIR (ctest gives one in build/). */
export function workDir(name) {
  const base = process.env.KANEDYN_WORK_DIR || join(SOURCE, 'build/viewer-tests');
  const dir = join(base, name);
  rmSync(dir, { recursive: true, force: true });
  mkdirSync(dir, { recursive: true });
  return dir;
}

/** Runs `kanedyn ARGS...` in cwd: { code, out, err, seconds }. */
export function kanedyn(cwd, ...args) {
  const t0 = process.hrtime.bigint();
  const r = spawnSync(TOOL, args, { cwd, encoding: 'utf8', maxBuffer: 1 << 28 });
  const seconds = Number(process.hrtime.bigint() - t0) / 1e9;
  if (r.error) throw r.error;
  return { code: r.status, out: r.stdout, err: r.stderr, seconds };
}

/** A trajectory CSV: { header, rows } with rows as arrays of numbers. */
export function readCsv(path) {
  const lines = readFileSync(path, 'utf8').split('\n').filter((l) => l.length);
  const header = lines[0].split(',');
  const rows = lines.slice(1).map((l) => l.split(',').map(Number));
  return { header, rows };
}

/** The CSV's value of column c at time t, linear between the rows around t. */
export function interpolate(csv, c, t) {
  const { rows } = csv;
  let i = 0;
  while (i + 2 < rows.length && rows[i + 1][0] <= t) ++i;
  const [a, b] = [rows[i], rows[Math.min(i + 1, rows.length - 1)]];
  const u = b[0] > a[0] ? (t - a[0]) / (b[0] - a[0]) : 0;
  return a[c] + u * (b[c] - a[c]);
}

/** The JSON a page written by kanedyn view holds. */
export function pageData(htmlPath) {
  const html = readFileSync(htmlPath, 'utf8');
  const m = html.match(/<script id="kanedyn-data" type="application\/json">(.*?)<\/script>/s);
  if (!m) throw new Error(`${htmlPath}: no kanedyn-data element`);
  return JSON.parse(m[1]);
}
