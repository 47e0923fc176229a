// The page's data (kanedyn view's JSON, docs/viewer.md): the model and the trajectory's
// columns, decoded from base64 into typed arrays.

/** Bytes of a base64 string. */
export function decodeBase64(text) {
  const raw = atob(text);
  const bytes = new Uint8Array(raw.length);
  for (let i = 0; i < raw.length; ++i) bytes[i] = raw.charCodeAt(i);
  return bytes;
}

/**
 * The trajectory as columns: { names, rows, column(name), index(name) }. f64 columns stay
 * Float64Array (time and mass centres), the rest Float32Array, each a view of its block.
 */
export function decodeTrajectory(d) {
  const rows = d.rows;
  const columns = new Array(d.columns.length);
  const f64 = d.f64 ? new Float64Array(decodeBase64(d.f64).buffer) : new Float64Array(0);
  const f32 = d.f32 ? new Float32Array(decodeBase64(d.f32).buffer) : new Float32Array(0);
  if (f64.length !== rows * d.f64_columns.length || f32.length !== rows * d.f32_columns.length) {
    throw new Error(`the page's data is damaged: ${f64.length} + ${f32.length} numbers for ${rows} rows`);
  }
  d.f64_columns.forEach((c, i) => { columns[c] = f64.subarray(i * rows, (i + 1) * rows); });
  d.f32_columns.forEach((c, i) => { columns[c] = f32.subarray(i * rows, (i + 1) * rows); });
  const byName = new Map(d.columns.map((n, i) => [n, i]));
  return {
    names: d.columns,
    rows,
    columns,
    index: (name) => byName.get(name),
    column: (name) => columns[byName.get(name)],
  };
}

/** Reads the JSON the page holds in <script id="kanedyn-data">. */
export function readPageData(doc) {
  const el = doc.getElementById('kanedyn-data');
  return JSON.parse(el.textContent);
}
