// A mode page (kanedyn view --mode) plots the mode's coordinates instead of the energy: a
// mode's shape is drawn without its growth or decay, so its "energy" swings by an amount that
// means nothing. Only the coordinates that move are worth a line.

/**
 * The mode columns to plot: those whose swing (largest minus smallest value) is at least
 * `share` of the largest swing, largest first, at most `max` of them (the palette's eight
 * colours); the others stay in the column picker.
 */
export function modePlotColumns(traj, names, max = 8, share = 0.05) {
  const swings = names.map((name) => {
    const c = traj.column(name);
    let lo = Infinity;
    let hi = -Infinity;
    for (let r = 0; r < c.length; ++r) {
      lo = Math.min(lo, c[r]);
      hi = Math.max(hi, c[r]);
    }
    return { name, swing: hi - lo };
  });
  const largest = Math.max(0, ...swings.map((s) => s.swing));
  if (!(largest > 0)) return names.slice(0, Math.min(max, names.length));
  return swings
    .filter((s) => s.swing >= share * largest)
    .sort((a, b) => b.swing - a.swing)
    .slice(0, max)
    .map((s) => s.name);
}
