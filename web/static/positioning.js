// The chart of a laser positioning test as a laser report draws it ([ISO 230-2]): the mean
// deviation at each target in each direction with its ±2s band, every run faint behind them,
// and the axis figures A, B, E, M, R written on the chart. Data attributes carry the plotted
// numbers so the chart can be checked against the API.

import { axesGrid, el, r2, ticks } from './charts.js';
import { $, h } from './dom.js';
import { formatNumber } from './format.js';

const DIRS = [
  { key: 'up', arrow: '↑', cls: 'dir-up' },
  { key: 'down', arrow: '↓', cls: 'dir-down' },
];

// The readings of each run and direction, in target order, from the stored samples.
function runLines(samples) {
  const runs = new Map();
  const n = (samples.run || []).length;
  for (let i = 0; i < n; ++i) {
    const key = `${samples.run[i]} ${samples.direction[i] > 0 ? 'up' : 'down'}`;
    if (!runs.has(key)) runs.set(key, { run: samples.run[i], dir: samples.direction[i] > 0 ? 'up' : 'down', pts: [] });
    runs.get(key).pts.push([samples.target_mm[i], samples.deviation_um[i]]);
  }
  for (const r of runs.values()) r.pts.sort((a, b) => a[0] - b[0]);
  return [...runs.values()];
}

function pathOf(pts, px, py) {
  return pts.map(([x, y], i) => `${i ? 'L' : 'M'}${r2(px(x))},${r2(py(y))}`).join('');
}

function figureText(r) {
  const f = (key) => (Number.isFinite(r[key]) ? r[key].toFixed(2) : '—');
  return [
    `A ${f('accuracy_um')} µm`,
    `B ${f('reversal_value_um')} µm`,
    `E ${f('systematic_deviation_um')} µm`,
    `M ${f('mean_deviation_range_um')} µm`,
    `R ${f('repeatability_um')} µm`,
  ];
}

export function positioningChart(r, samples, { title }) {
  const t = r.targets || {};
  const x = t.target_mm || [];
  const W = 900, H = 380, L = 70, R = 150, T = 36, B = 52;
  const runs = runLines(samples || {});
  const ys = runs.flatMap((run) => run.pts.map((p) => p[1]));
  for (const d of DIRS) {
    (t[`mean_${d.key}_um`] || []).forEach((m, i) => ys.push(m + 2 * t[`s_${d.key}_um`][i], m - 2 * t[`s_${d.key}_um`][i]));
  }
  let ylo = Math.min(...ys);
  let yhi = Math.max(...ys);
  const pad = (yhi - ylo) * 0.08 || 0.5;
  ylo -= pad;
  yhi += pad;
  const xmin = Math.min(...x);
  const xmax = Math.max(...x);
  const px = (v) => L + ((v - xmin) / (xmax - xmin || 1)) * (W - L - R);
  const py = (v) => T + (1 - (v - ylo) / (yhi - ylo || 1)) * (H - T - B);
  const svg = el('svg', {
    viewBox: `0 0 ${W} ${H}`, width: W, height: H, role: 'img', class: 'chart positioning',
    'data-testid': 'positioning-plot', 'data-targets': x.length, 'data-runs': runs.length,
    'aria-label': `${title}: mean deviation ±2s at ${x.length} targets in both directions, ${runs.length} runs.`,
  });
  svg.append(el('title', {}, title));
  svg.append(axesGrid({ W, H, L, R, T, B, px, py, xt: ticks(xmin, xmax, 8), yt: ticks(ylo, yhi, 6) }));
  svg.append(el('text', { x: r2(L + (W - L - R) / 2), y: H - 10, 'text-anchor': 'middle', class: 'axis-title' }, 'Target position (mm)'));
  const my = r2((T + H - B) / 2);
  svg.append(el('text', { x: 16, y: my, 'text-anchor': 'middle', class: 'axis-title', transform: `rotate(-90 16 ${my})` }, 'Deviation (µm)'));
  for (const run of runs) {
    svg.append(el('path', { d: pathOf(run.pts, px, py), class: `run-line ${run.dir === 'up' ? 'dir-up' : 'dir-down'}`, 'data-run': run.run, 'data-direction': run.dir }));
  }
  for (const d of DIRS) {
    const mean = t[`mean_${d.key}_um`] || [];
    const s = t[`s_${d.key}_um`] || [];
    const hiPts = x.map((xi, i) => [xi, mean[i] + 2 * s[i]]);
    const loPts = x.map((xi, i) => [xi, mean[i] - 2 * s[i]]).reverse();
    svg.append(el('polygon', {
      points: [...hiPts, ...loPts].map(([a, b]) => `${r2(px(a))},${r2(py(b))}`).join(' '),
      class: `band ${d.cls}`, 'data-testid': `band-${d.key}`,
      'data-width-um': JSON.stringify(s.map((v) => 4 * v)),
    }));
    svg.append(el('path', {
      d: pathOf(x.map((xi, i) => [xi, mean[i]]), px, py), class: `data-line mean ${d.cls}`,
      'data-testid': `mean-${d.key}`, 'data-values': JSON.stringify(mean),
    }));
  }
  const notes = el('g', { class: 'legend', 'data-testid': 'positioning-figures' });
  figureText(r).forEach((line, i) => notes.append(el('text', { x: W - R + 14, y: T + 18 + i * 20 }, line)));
  DIRS.forEach((d, i) => {
    const g = el('g', { transform: `translate(${W - R + 14},${T + 140 + i * 22})` });
    g.append(el('line', { x1: 0, y1: 0, x2: 22, y2: 0, class: `data-line mean ${d.cls}` }));
    g.append(el('text', { x: 28, y: 0, dy: '0.35em' }, `${d.arrow} x̄ ± 2s`));
    notes.append(g);
  });
  svg.append(notes);
  return svg;
}

export function renderPositioningPlot(item, f) {
  const container = $('#polar-plot');
  const note = $('#plot-note');
  const r = f?.results || {};
  if (!(r.targets?.target_mm || []).length) {
    container.replaceChildren(h('p', { class: 'placeholder' }, 'No positioning figures to plot for this measurement.'));
    note.textContent = '';
    return;
  }
  const title = `Positioning of ${r.axis || item.test_id || 'the axis'} — ${item.machine_id || ''}`.trim();
  container.replaceChildren(positioningChart(r, f?.measurement?.samples, { title }));
  const corrections = [];
  if (r.air?.applied) corrections.push(`air: n = ${Number(r.air.refractive_index).toFixed(9)} (${formatNumber(r.air.correction_at_end_um)} µm at ${formatNumber(r.air.end_of_axis_mm)} mm)`);
  if (r.material?.applied) corrections.push(`material to 20 °C: ${formatNumber(r.material.correction_at_end_um)} µm at the end`);
  note.textContent =
    `ISO 230-2 ${r.iso230_2_compliant ? '' : '(not compliant: ' + (r.warnings || []).join('; ') + ') '}` +
    `— ${r.runs} runs, ${r.target_count} targets, ${r.cycle} cycle` +
    (corrections.length ? `; corrections applied: ${corrections.join('; ')}` : '; no corrections applied') + '.';
}
