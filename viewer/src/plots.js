// uPlot plots against time: energy, and the columns the user picks. One cursor for all
// (uPlot's sync), a line at the animation's time, and a click seeks there.
import uPlot from 'uplot';
import 'uplot/dist/uPlot.min.css';

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

const PALETTE = ['#1f77b4', '#d62728', '#2ca02c', '#9467bd', '#ff7f0e', '#17becf', '#8c564b', '#e377c2'];

export function createPlot(container, traj, names, { width, height, getTime, seek, title }) {
  const series = [{ label: 't' }];
  const data = [traj.columns[0]];
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
    axes: [{ label: 't (s)' }, { size: 70 }],
    cursor: { sync: { key: SYNC }, drag: { x: false, y: false } },
    legend: { live: true },
    plugins: [timeMarker(getTime)],
  };
  const plot = new uPlot(opts, data, container);
  plot.over.addEventListener('click', (e) => {
    seek(plot.posToVal(e.offsetX, 'x'));
  });
  return plot;
}
