// uPlot plots against time: energy, and the columns the user picks. One cursor for all
// (uPlot's sync), a line at the animation's time, and a click seeks there.
// The value axis labels its ticks by ticks.js: an offset and a power of ten written once in
// the plot's top-left corner when the range is tiny next to the values.
import uPlot from 'uplot';
import 'uplot/dist/uPlot.min.css';
import { tickLabels } from './ticks.js';
import { locate } from './interp.js';

const SYNC = 'kanedyn';

/** Draws a vertical line at the current time. */
function timeMarker(getTime) {
  return {
    hooks: {
      draw: (u) => {
        const x = u.valToPos(getTime(), 'x', true);
        const { top, height } = u.bbox;
        const ctx = u.ctx;
        ctx.save();
        ctx.strokeStyle = '#d03030';
        ctx.lineWidth = 1.5 * devicePixelRatio;
        ctx.beginPath();
        ctx.moveTo(x, top);
        ctx.lineTo(x, top + height);
        ctx.stroke();
        ctx.restore();
      },
    },
  };
}

/**
 * The value axis's tick labels, and its offset and scale text drawn in the plot area's
 * top-left corner; `state.text` holds that text (the page hook reads it).
 */
function valueAxis(state) {
  return {
    size: 70,
    values: (u, splits, axisIdx, space, incr) => {
      const r = tickLabels(splits, incr);
      state.text = r.text;
      state.labels = r.labels;
      return r.labels;
    },
  };
}

function axisText(state) {
  return {
    hooks: {
      draw: (u) => {
        if (!state.text) return;
        const ctx = u.ctx;
        const px = devicePixelRatio;
        ctx.save();
        ctx.font = `${12 * px}px sans-serif`;
        ctx.textBaseline = 'top';
        ctx.textAlign = 'left';
        const x = u.bbox.left + 4 * px;
        const y = u.bbox.top + 3 * px;
        const w = ctx.measureText(state.text).width;
        ctx.fillStyle = 'rgba(255, 255, 255, 0.8)';
        ctx.fillRect(x - 2 * px, y - 2 * px, w + 4 * px, 16 * px);
        ctx.fillStyle = '#222';
        ctx.fillText(state.text, x, y);
        ctx.restore();
      },
    },
  };
}

/**
 * The legend (the readout under the plot) shows the values at the animation's time whenever
 * the cursor is not on a plot: at load, after the cursor leaves, and while playing. uPlot
 * shows "--" for a cursor off the plot; its setLegend hook puts the current row back.
 */
function legendAtTime(times, getTime) {
  const row = () => {
    const { i, u } = locate(times, getTime());
    return u > 0.5 ? Math.min(i + 1, times.length - 1) : i;
  };
  return {
    hooks: {
      setLegend: (u) => {
        if (u.legend.idx == null) u.setLegend({ idx: row() }, false);
      },
    },
    row,
  };
}

const PALETTE = ['#1f77b4', '#d62728', '#2ca02c', '#9467bd', '#ff7f0e', '#17becf', '#8c564b', '#e377c2'];

export function createPlot(container, traj, names, { width, height, getTime, seek, title }) {
  const axis = { text: '', labels: [] };
  const series = [{ label: 't' }];
  const data = [traj.columns[0]];
  const legend = legendAtTime(traj.columns[0], getTime);
  names.forEach((name, i) => {
    // Points only for a lone row (the initial state), where a line has no length.
    series.push({ label: name, stroke: PALETTE[i % PALETTE.length], width: 1.5, points: { show: traj.rows < 2 } });
    data.push(traj.column(name));
  });
  const opts = {
    title,
    width,
    height,
    series,
    scales: { x: { time: false } },
    axes: [{ label: 't (s)' }, valueAxis(axis)],
    cursor: { sync: { key: SYNC }, drag: { x: false, y: false } },
    legend: { live: true },
    plugins: [timeMarker(getTime), axisText(axis), legend],
  };
  const plot = new uPlot(opts, data, container);
  plot.kanedynAxis = axis;
  // The readout at the animation's time unless the cursor is on the plot (or on the other
  // plot, whose cursor this one's follows).
  plot.showTime = () => {
    if (!(plot.cursor.left >= 0)) plot.setLegend({ idx: legend.row() }, false);
  };
  plot.showTime();
  plot.over.addEventListener('click', (e) => {
    seek(plot.posToVal(e.offsetX, 'x'));
  });
  return plot;
}
