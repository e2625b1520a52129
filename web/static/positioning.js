// The chart of a laser positioning test as a laser report draws it ([ISO 230-2]): the mean
// deviation at each target in each direction with its ±2s band, every run faint behind them,
// and the axis figures A, B, E, M, R written on the chart. Data attributes carry the plotted
// numbers so the chart can be checked against the API.

import { apiFetchFile } from './api.js';
import { handleAuth } from './auth.js';
import { axesGrid, el, r2, ticks } from './charts.js';
import { $, asProblem, downloadBlob, h, problemContent, setMessage } from './dom.js';
import { formatNumber, plural } from './format.js';

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
    `— ${plural(r.runs, 'run')}, ${plural(r.target_count, 'target')}, ${r.cycle} cycle` +
    (corrections.length ? `; corrections applied: ${corrections.join('; ')}` : '; no corrections applied') + '.';
}

// ---------------------------------------------------------------- conditions, compensation

const fixedOr = (v, d) => (typeof v === 'number' && Number.isFinite(v) ? v.toFixed(d) : '—');

// The air and the material during the test and the corrections made of them, in words and
// units (as the PDF report's conditions): a block of its own, not rows of the figures.
export function positioningConditions(r) {
  const air = r?.air || {};
  const mat = r?.material || {};
  const rows = [
    ['air_temperature_c', 'Air temperature', fixedOr(air.air_temperature_c, 2), '°C'],
    ['air_pressure_pa', 'Air pressure', fixedOr(air.air_pressure_pa / 100, 1), 'hPa'],
    ['air_humidity_pct', 'Air humidity (relative)', fixedOr(air.air_humidity_pct, 1), '%'],
    ['co2_ppm', 'CO₂ content of the air', fixedOr(air.co2_ppm, 0), 'ppm'],
    ['laser_wavelength_nm', 'Laser wavelength (vacuum)', fixedOr(air.laser_wavelength_nm, 3), 'nm'],
    ['refractive_index', 'Refractive index of the air', fixedOr(air.refractive_index, 9), ''],
    ['material_temperature_c', 'Material temperature', fixedOr(mat.material_temperature_c, 2), '°C'],
    ['reference_temperature_c', 'Reference temperature', fixedOr(mat.reference_temperature_c, 2), '°C'],
    ['expansion_ppm_per_k', 'Expansion coefficient α', fixedOr(mat.expansion_ppm_per_k, 2), 'µm/(m·K)'],
  ].filter(([key]) => typeof (key in air ? air : mat)[key] === 'number');
  const correction = (o, what) => [what, o.applied ? 'yes' : 'no', o.applied ? `${formatNumber(o.correction_at_end_um, '_um')} µm at ${formatNumber(o.end_of_axis_mm, '_mm')} mm` : '—'];
  const corrections = [];
  if (r?.air) corrections.push(['air', ...correction(air, 'Air: the laser wavelength in the air (refractive index)')]);
  if (r?.material) corrections.push(['material', ...correction(mat, 'Material: the length at the reference temperature (expansion)')]);
  return h(
    'section',
    { class: 'positioning-conditions', 'data-testid': 'positioning-conditions' },
    h('h3', {}, 'Conditions of the measurement'),
    h(
      'table',
      { class: 'figures small' },
      h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Condition'), h('th', { scope: 'col', class: 'num' }, 'Value'), h('th', { scope: 'col', class: 'unit' }, 'Unit'))),
      h('tbody', {}, ...rows.map(([key, label, v, unit]) => h('tr', { 'data-key': key }, h('th', { scope: 'row' }, label), h('td', { class: 'num' }, v), h('td', { class: 'unit' }, unit)))),
    ),
    air.equation ? h('p', { class: 'note' }, `The refractive index of the air from the ${air.equation}.`) : '',
    corrections.length
      ? h(
          'table',
          { class: 'figures small', 'data-testid': 'positioning-corrections' },
          h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Correction of the readings'), h('th', { scope: 'col' }, 'Applied'), h('th', { scope: 'col', class: 'num' }, 'At the end of the axis'))),
          h('tbody', {}, ...corrections.map(([key, what, applied, size]) => h('tr', { 'data-key': key }, h('th', { scope: 'row' }, what), h('td', { 'data-key': 'applied' }, applied), h('td', { class: 'num' }, size)))),
        )
      : '',
  );
}

// The compensation table a controller loads (GET …/compensation?format=), saved under the
// server's file name.
const COMPENSATION_FORMATS = [
  ['linuxcnc', 'LinuxCNC (.comp)', 'kinemetric-compensation.comp'],
  ['sinumerik', 'SINUMERIK (.spf)', 'kinemetric-compensation.spf'],
  ['csv', 'CSV', 'kinemetric-compensation.csv'],
];

async function saveCompensation(id, format, fallback, status) {
  try {
    const { blob, filename } = await apiFetchFile(`/api/v1/measurements/${encodeURIComponent(id)}/compensation?format=${format}`, fallback);
    downloadBlob(blob, filename);
    setMessage(status, 'success', `Saved as ${filename}.`);
  } catch (err) {
    if (!handleAuth(err)) setMessage(status, 'error', ...problemContent(asProblem(err, 'No compensation table')));
  }
}

export function compensationBlock(item) {
  const status = h('div', { class: 'message', 'data-testid': 'compensation-status', 'aria-live': 'polite', hidden: true });
  return h(
    'section',
    { class: 'compensation-downloads no-print', 'data-testid': 'compensation-downloads' },
    h('h3', {}, 'Compensation table for the controller'),
    h('p', { class: 'note' }, 'The trims of each target, as the control loads them: LinuxCNC screw compensation (COMP_FILE_TYPE 1), a SINUMERIK leadscrew error compensation program, or CSV.'),
    h(
      'p',
      { class: 'dialog-actions' },
      ...COMPENSATION_FORMATS.map(([format, label, fallback]) =>
        h('button', { type: 'button', class: 'secondary small', 'data-testid': `compensation-${format}`, 'data-format': format, onclick: () => saveCompensation(item.id, format, fallback, status) }, label),
      ),
    ),
    status,
  );
}
