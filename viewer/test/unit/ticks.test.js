// The value axis's tick labels (src/ticks.js): an offset and a power of ten when the range is
// tiny next to the values, plain decimals otherwise. Every label is checked by reading it
// back: scale x label + offset must give the tick to within half a step (what a label that
// rounds to the step's decimals can promise), and neighbouring labels must differ.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { decimalsFor, offsetText, tickLabels } from '../../src/ticks.js';

/** Ticks lo, lo + step, ..., as uPlot makes them (multiples of the step). */
const ticks = (first, step, count) => Array.from({ length: count }, (_, i) => first + i * step);

function readBack(values, step, r) {
  values.forEach((v, i) => {
    const back = r.scale * Number(r.labels[i]) + r.offset;
    assert.ok(Math.abs(back - v) <= 0.5 * step, `tick ${v}: label '${r.labels[i]}' reads back as ${back}`);
  });
  assert.equal(new Set(r.labels).size, r.labels.length, `labels all different: ${r.labels}`);
  for (const l of r.labels) assert.ok(l.length <= 8, `label '${l}' is short`);
}

test('1234.5678901 give or take 1e-7: an offset, a scale, short labels', () => {
  const step = 5e-8;
  const values = ticks(1234.5678901 - 1e-7, step, 5);
  const r = tickLabels(values, step);
  assert.notEqual(r.offset, 0);
  assert.equal(r.scale, 1e-7);
  // The offset is the ticks' common digits: 1234.56789 to the microjoule (p = 1e-6 for a
  // range of 2e-7), written with them and no more.
  assert.equal(r.text, '\u00d71e-7 +1234.56789');
  assert.ok(Math.abs(r.offset - 1234.56789) < 1e-9, String(r.offset));
  readBack(values, step, r);
  assert.deepEqual(r.labels, ['0.0', '0.5', '1.0', '1.5', '2.0']);
});

test('a tiny range of negative values: the offset is negative, the labels read back', () => {
  const step = 2e-9;
  const values = ticks(-52.000000011, step, 6);
  const r = tickLabels(values, step);
  assert.ok(r.offset < 0 && r.text.includes('-52'), r.text);
  readBack(values, step, r);
});

test('ordinary ranges: no offset, no scale, the values with the decimals of the step', () => {
  const cases = [
    [ticks(0, 0.5, 5), 0.5, ['0.0', '0.5', '1.0', '1.5', '2.0']],
    [ticks(-20, 10, 5), 10, ['-20', '-10', '0', '10', '20']],
    [ticks(1200, 25, 4), 25, ['1200', '1225', '1250', '1275']],
    [ticks(0.002, 0.001, 3), 0.001, ['0.002', '0.003', '0.004']],
  ];
  for (const [values, step, want] of cases) {
    const r = tickLabels(values, step);
    assert.equal(r.text, '', `${values}: ${r.text}`);
    assert.equal(r.offset, 0);
    assert.equal(r.scale, 1);
    assert.deepEqual(r.labels, want);
  }
});

test('a range spanning zero: no offset, a scale when tiny, no "-0"', () => {
  const step = 5e-8;
  const values = ticks(-1e-7, step, 5);
  const r = tickLabels(values, step);
  assert.equal(r.offset, 0);
  assert.equal(r.scale, 1e-7);
  assert.equal(r.text, '\u00d71e-7');
  readBack(values, step, r);
  assert.equal(r.labels[2], '0.0');
  // Round-off around zero (uPlot's splits are sums of steps) is not "-0".
  assert.equal(tickLabels([-1e-23, 1e-7], 1e-7).labels[0], '0');
});

test('large values: a power of ten, no offset when the range is comparable', () => {
  const step = 2e6;
  const values = ticks(0, step, 5);
  const r = tickLabels(values, step);
  assert.equal(r.offset, 0);
  assert.equal(r.scale, 1e6);
  assert.deepEqual(r.labels, ['0', '2', '4', '6', '8']);
});

test('a constant series: one tick or ticks of uPlot\'s padded range, readable', () => {
  // uPlot pads a constant 1234.5 J to a range of its own size; one tick alone is the value.
  assert.deepEqual(tickLabels([1234.5], 0), { labels: ['1234.5'], offset: 0, scale: 1, text: '' });
  assert.deepEqual(tickLabels([0], 0).labels, ['0']);
  const r = tickLabels(ticks(1000, 100, 5), 100);
  assert.deepEqual(r.labels, ['1000', '1100', '1200', '1300', '1400']);
  // Nulls and empty splits (uPlot passes them for a hidden tick) are blank labels.
  assert.deepEqual(tickLabels([], 1).labels, []);
  assert.deepEqual(tickLabels([null, 1, 2], 1).labels, ['', '1', '2']);
});

test('decimalsFor and offsetText', () => {
  assert.equal(decimalsFor(0.25), 2);
  assert.equal(decimalsFor(5), 0);
  assert.equal(decimalsFor(0.001), 3);
  assert.equal(decimalsFor(2.5e-8), 9);
  assert.equal(offsetText(1234.56789, 1e-6), '+1234.56789');
  assert.equal(offsetText(-52, 1e-8), '-52');
  assert.equal(offsetText(123456789.5, 0.1), '+1.234567895e8');
});
