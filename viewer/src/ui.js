// The page's elements: the 3D stage, the playback bar and the side panel with the plots.
import { hasJoints } from './joints.js';
import { hasConstraints, rollingDiscs } from './constraints.js';
import { modelFrames, tracePoints } from './traces.js';

/** document.createElement with attributes (on* as listeners) and children. */
export function h(tag, attrs = {}, ...children) {
  const el = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k.startsWith('on')) el.addEventListener(k.slice(2), v);
    else if (v === true) el.setAttribute(k, '');
    else if (v !== false && v != null) el.setAttribute(k, v);
  }
  el.append(...children);
  return el;
}

/** 2 -> '2nd', 11 -> '11th'. */
export function ordinal(n) {
  const s = n % 100 >= 11 && n % 100 <= 13 ? 'th' : ['th', 'st', 'nd', 'rd'][n % 10] || 'th';
  return `${n}${s}`;
}

export function layout(body, d) {
  const m = d.model;
  const canvas = h('canvas', { id: 'scene' });
  const tip = h('div', { class: 'tip', hidden: true });
  const stage = h('div', { class: 'stage' }, canvas, tip);
  const play = h('button', { id: 'play' }, 'Play');
  const speed = h('select', { id: 'speed', title: 'speed (times real time)' });
  const loop = h('input', { type: 'checkbox', id: 'loop', checked: true });
  const slider = h('input', { type: 'range', id: 'slider' });
  const time = h('span', { id: 'time' });
  const bar = h('div', { class: 'bar' }, play, speed,
    h('label', {}, loop, ' loop'), slider, time);
  const follow = h('select', { id: 'follow' }, h('option', { value: '-1' }, 'none'),
    ...m.bodies.map((b, k) => h('option', { value: String(k) }, `${k + 1} ${b.name}`)));
  const axes = h('input', { type: 'checkbox', id: 'axes' });
  // Shown (and on) for a jointed model only.
  const jointed = hasJoints(m);
  const joints = h('input', { type: 'checkbox', id: 'joints', checked: jointed });
  // Likewise for a model with constraints.
  const constrained = hasConstraints(m);
  const constraints = h('input', { type: 'checkbox', id: 'constraints', checked: constrained });
  const wheels = rollingDiscs(m).length > 0;
  // Likewise for a model with frames.
  const hasFrames = modelFrames(m).length > 0;
  const frames = h('input', { type: 'checkbox', id: 'frames', checked: hasFrames });
  // Traces: a checkbox per body (its mass centre) and per frame (its origin).
  const traceBoxes = new Map();
  const traceItems = tracePoints(m).map((p) => {
    const box = h('input', { type: 'checkbox', id: `trace-${p.name}`, value: p.name });
    traceBoxes.set(p.name, box);
    return h('label', { class: 'trace-item', title: p.kind === 'body' ? `the path of ${p.name}'s mass centre` : `the path of frame ${p.name}'s origin` },
      box, p.kind === 'body' ? ` G ${p.name}` : ` frame ${p.name}`);
  });
  const traceList = h('details', { id: 'traces' }, h('summary', {}, 'trace paths'), h('div', { class: 'trace-list' }, ...traceItems));
  const loops = constrained && m.constraints.length > rollingDiscs(m).length;
  const fit = h('button', { id: 'fit' }, 'Fit view');
  const listId = 'kanedyn-columns';
  const picker = h('input', { type: 'text', id: 'picker', list: listId, placeholder: 'add a column, e.g. ' + (d.columns[1] || 't'), autocomplete: 'off' });
  const list = h('datalist', { id: listId }, ...d.columns.slice(1).map((c) => h('option', { value: c })));
  const chips = h('div', { class: 'chips' });
  const energyPlot = h('div', { id: d.mode_columns ? 'mode-plot' : 'energy-plot' });
  const pickedPlot = h('div', { id: 'picked-plot' });
  const plots = h('div', { class: 'plots' }, energyPlot, picker, list, chips, pickedPlot);
  const n = m.bodies.length;
  const note = d.stride > 1
    ? h('p', { class: 'note', id: 'decimated' }, `Decimated: the trajectory has ${d.rows_in_file} rows; this page holds every ${ordinal(d.stride)} row and the last (${d.rows} rows).`)
    : '';
  const about = h('div', { class: 'about' },
    h('h1', {}, m.name || m.file),
    h('p', {}, `${n} ${n === 1 ? 'body' : 'bodies'}, ${d.source === 'initial state' ? 'the initial state' : `${d.source}, ${d.rows_in_file} rows`}`),
    note,
    h('p', { class: 'controls' }, h('label', {}, 'follow ', follow), ' ',
      h('label', {}, axes, ' body axes'), ' ',
      jointed ? h('label', {}, joints, ' joints') : '', jointed ? ' ' : '',
      constrained ? h('label', {}, constraints, ' constraints') : '', constrained ? ' ' : '',
      hasFrames ? h('label', {}, frames, ' frames') : '', hasFrames ? ' ' : '', fit),
    traceList,
    h('p', { class: 'hint' }, 'Drag: orbit; wheel: zoom; right-drag: pan. Space: play/pause; arrows: step a row. Click a plot to seek. Blue arrow: gravity; lines: O_J \u2192 Q_K \u2192 O_K where a joint or bushing joins K to J.',
      jointed ? ' Violet: joint axes and balls at Q_K; orange arrowheads: sliding.' : '',
      wheels ? ' Wheels: rolling discs; green: their contact points with the ground.' : '',
      loops ? ' Magenta: loop closures, the point of the body (solid) and of the other (wire ball); lines: a distance, or a hinge\u2019s two axes.' : '',
      hasFrames ? ' Small RGB axes: the model\u2019s frames.' : ''));
  const side = h('div', { class: 'side' }, about, plots);
  const main = h('div', { class: 'main' }, h('div', { class: 'left' }, stage, bar), side);
  body.append(main);
  return { canvas, tip, stage, play, speed, loop, slider, time, follow, axes, joints, constraints, frames, traceBoxes, traceList, fit, picker, chips, energyPlot, pickedPlot, plots };
}
