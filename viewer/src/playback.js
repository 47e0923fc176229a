// Play and pause, speed 0.1x to 10x of real time, loop, the time slider and the keyboard
// (space: play or pause; left and right arrows: the previous or next row).
import { locate } from './interp.js';

export const SPEEDS = [0.1, 0.2, 0.5, 1, 2, 5, 10];

/**
 * The time after `dt` seconds of wall clock at `speed`, looping or stopping at the end:
 * { t, playing }.
 */
export function step(t, dt, speed, start, end, loop) {
  const next = t + dt * speed;
  if (next <= end) return { t: next, playing: true };
  if (!loop || end <= start) return { t: end, playing: false };
  return { t: start + ((next - start) % (end - start)), playing: true };
}

/** The row time after (dir = +1) or before (dir = -1) time t, staying within the rows. */
export function neighbourRow(times, t, dir) {
  const n = times.length;
  if (t < times[0]) return times[0];
  const { i, u } = locate(times, t); // times[i] <= t <= times[i + 1]
  if (dir > 0) return u >= 1 ? times[n - 1] : times[Math.min(i + 1, n - 1)];
  return t > times[i] ? times[i] : times[Math.max(i - 1, 0)];
}

export function createPlayback(ui, motion, { seek, getTime }) {
  let playing = false;
  let speed = 1;
  const span = motion.end - motion.start;
  ui.slider.min = String(motion.start);
  ui.slider.max = String(motion.end);
  ui.slider.step = 'any';
  ui.speed.replaceChildren(...SPEEDS.map((s) => {
    const o = document.createElement('option');
    o.value = String(s);
    o.textContent = `${s}\u00d7`;
    o.selected = s === 1;
    return o;
  }));
  // Enough decimals to tell rows apart: one more than the row spacing needs.
  const spacing = span / Math.max(motion.times.length - 1, 1);
  const digits = span > 0 ? Math.max(2, Math.min(6, Math.ceil(-Math.log10(spacing)) + 1)) : 2;

  function setPlaying(on) {
    playing = on && span > 0;
    if (playing && getTime() >= motion.end && !ui.loop.checked) seek(motion.start);
    ui.play.textContent = playing ? 'Pause' : 'Play';
  }
  function setSpeed(s) {
    speed = Math.min(Math.max(Number(s), 0.1), 10);
    ui.speed.value = String(speed);
  }
  ui.play.addEventListener('click', () => setPlaying(!playing));
  ui.speed.addEventListener('change', () => setSpeed(ui.speed.value));
  ui.slider.addEventListener('input', () => seek(Number(ui.slider.value)));
  document.addEventListener('keydown', (e) => {
    if (e.target instanceof HTMLInputElement && e.target.type === 'text') return;
    if (e.target instanceof HTMLSelectElement) return;
    if (e.key === ' ') {
      // Not also the focused button's or checkbox's own response to space.
      e.preventDefault();
      if (e.target instanceof HTMLElement && e.target !== document.body) e.target.blur();
      setPlaying(!playing);
    } else if (e.key === 'ArrowRight' || e.key === 'ArrowLeft') {
      e.preventDefault();
      setPlaying(false);
      seek(neighbourRow(motion.times, getTime(), e.key === 'ArrowRight' ? 1 : -1));
    }
  });

  return {
    setPlaying,
    setSpeed,
    playing: () => playing,
    /** The time the next frame shows. */
    advance(t, dt) {
      if (!playing) return t;
      const s = step(t, dt, speed, motion.start, motion.end, ui.loop.checked);
      if (!s.playing) setPlaying(false);
      return s.t;
    },
    show(t) {
      ui.slider.value = String(t);
      ui.time.textContent = `t = ${t.toFixed(digits)} s / ${motion.end.toFixed(digits)} s`;
    },
  };
}
