// Servo loads on the dashboard: a machine's joint-health panel (the newest estimate's resistance
// per leg as bars against the level-2 and level-3 limits, the level in colour and in words, and
// the history of every stored estimate as one line per leg) and, for one servo record, the
// strut forces measured against the machine model's. Every chart carries data-* attributes with
// the plotted numbers so what is drawn can be checked against the API.

import { ApiError, api } from './api.js';
import { handleAuth } from './auth.js';
import { axesGrid, el, r2, ticks } from './charts.js';
import { $, asProblem, errorBox, h, problemContent, setMessage } from './dom.js';
import { formatTimestamp } from './format.js';
import { refusalContent } from './roles.js';
import { state } from './state.js';

const LEVEL_WORDS = { 1: 'level 1 — normal', 2: 'level 2 — warn', 3: 'level 3 — stop' };
const DAY_MS = 24 * 3600 * 1000;

export const levelWords = (level) => LEVEL_WORDS[level] || `level ${level}`;

// ---------------------------------------------------------------- joint health: current

// The newest estimate: one bar a leg (with ± σ), the level-2 and level-3 limits of each leg
// (the ratios × its reference) as lines across its slot, the level under each bar in words.
export function renderJointBars(estimate) {
  const legs = estimate.legs;
  const { level2_ratio: l2, level3_ratio: l3 } = estimate.limits;
  const W = 640;
  const H = 300;
  const L = 64;
  const R = 12;
  const T = 28;
  const B = 58;
  const top = Math.max(...legs.map((g) => Math.max(g.resistance_Nm + (g.sigma_Nm || 0), l3 * g.reference_Nm))) * 1.1 || 1;
  const yt = ticks(0, top, 5);
  const slot = (W - L - R) / legs.length;
  const py = (v) => T + (1 - v / top) * (H - T - B);
  const svg = el('svg', {
    viewBox: `0 0 ${W} ${H}`,
    width: W,
    height: H,
    role: 'img',
    class: 'chart joint-bars',
    'data-testid': 'joint-bars',
    'aria-label': `Joint resistance per leg: ${legs.map((g) => `leg ${g.leg} ${g.resistance_Nm.toFixed(2)} N·m, ${levelWords(g.level)}`).join('; ')}.`,
  });
  svg.append(el('title', {}, 'Joint resistance per leg with the level-2 and level-3 limits'));
  svg.append(axesGrid({ W, H, L, R, T, B, px: (v) => v, py, xt: { values: [], step: 1 }, yt }));
  const my = r2((T + H - B) / 2);
  svg.append(el('text', { x: 16, y: my, 'text-anchor': 'middle', class: 'axis-title', transform: `rotate(-90 16 ${my})` }, 'resistance (N·m)'));
  legs.forEach((g, i) => {
    const x0 = L + i * slot;
    const bar = el('g', { class: `leg-bar level-${g.level}`, 'data-testid': 'joint-bar', 'data-leg': g.leg, 'data-level': g.level, 'data-resistance-nm': g.resistance_Nm });
    bar.append(el('rect', { x: r2(x0 + slot * 0.25), y: r2(py(g.resistance_Nm)), width: r2(slot * 0.5), height: r2(py(0) - py(g.resistance_Nm)), class: 'bar-fill' }));
    if (g.sigma_Nm) {
      const xc = r2(x0 + slot / 2);
      bar.append(el('line', { x1: xc, x2: xc, y1: r2(py(Math.max(0, g.resistance_Nm - g.sigma_Nm))), y2: r2(py(g.resistance_Nm + g.sigma_Nm)), class: 'error-bar' }));
    }
    for (const [ratio, cls] of [[l2, 'level2'], [l3, 'level3']]) {
      const v = ratio * g.reference_Nm;
      bar.append(el('line', { x1: r2(x0 + 4), x2: r2(x0 + slot - 4), y1: r2(py(v)), y2: r2(py(v)), class: `limit ${cls}`, 'data-testid': `limit-${cls}`, 'data-value-nm': v }));
    }
    bar.append(el('text', { x: r2(x0 + slot / 2), y: H - B + 18, 'text-anchor': 'middle', class: 'tick' }, `Leg ${g.leg}`));
    bar.append(el('text', { x: r2(x0 + slot / 2), y: H - B + 36, 'text-anchor': 'middle', class: `level-text level-${g.level}` }, levelWords(g.level).replace(/ — .*/, '')));
    svg.append(bar);
  });
  const legend = el('g', { class: 'legend' });
  [['limit level2', `level 2 limit (${l2} × reference)`], ['limit level3', `level 3 limit (${l3} × reference)`]].forEach(([cls, label], k) => {
    const g = el('g', { transform: `translate(${L + k * 290},${T - 14})` });
    g.append(el('line', { x1: 0, y1: 0, x2: 26, y2: 0, class: cls }));
    g.append(el('text', { x: 32, y: 0, dy: '0.35em' }, label));
    legend.append(g);
  });
  svg.append(legend);
  return svg;
}

// The newest estimate's legs as a table: value, ratio, the level in colour and words, evidence.
function jointTable(estimate) {
  const table = h(
    'table',
    { class: 'figures joint-table', 'data-testid': 'joint-table' },
    h('thead', {}, h('tr', {}, h('th', {}, 'Leg'), h('th', {}, 'Resistance (N·m)'), h('th', {}, '× reference'), h('th', {}, 'Level'), h('th', {}, 'Evidence'))),
    h(
      'tbody',
      {},
      ...estimate.legs.map((g) =>
        h(
          'tr',
          { 'data-testid': 'joint-leg', 'data-leg': g.leg, 'data-level': g.level },
          h('td', {}, `Leg ${g.leg}`),
          h('td', {}, `${g.resistance_Nm.toFixed(2)} ± ${(g.sigma_Nm || 0).toFixed(2)}`),
          h('td', {}, g.ratio.toFixed(2)),
          h('td', {}, h('span', { class: `level-badge level-${g.level}`, 'data-testid': 'joint-level' }, levelWords(g.level))),
          h('td', { class: 'evidence' }, g.evidence),
        ),
      ),
    ),
  );
  return h('div', { class: 'joint-table-box' }, table);
}

// ---------------------------------------------------------------- joint health: history

// Every estimate, oldest first: resistance over reference per leg (one line a leg), with the
// level-2 and level-3 ratios of the newest estimate as horizontal lines.
export function renderJointHistory(history) {
  const est = history.estimates;
  const { level2_ratio: l2, level3_ratio: l3 } = history.limits;
  const W = 640;
  const H = 280;
  const L = 56;
  const R = 90;
  const T = 16;
  const B = 52;
  const n = est.length;
  const top = Math.max(l3, ...est.flatMap((e) => e.legs.map((g) => g.ratio))) * 1.1;
  const yt = ticks(0, top, 5);
  const px = (i) => L + (n > 1 ? i / (n - 1) : 0.5) * (W - L - R);
  const py = (v) => T + (1 - v / top) * (H - T - B);
  const svg = el('svg', {
    viewBox: `0 0 ${W} ${H}`,
    width: W,
    height: H,
    role: 'img',
    class: 'chart joint-history',
    'data-testid': 'joint-history-chart',
    'data-estimates': n,
    'aria-label': `Joint resistance over its reference for ${n} estimate${n === 1 ? '' : 's'}, one line a leg.`,
  });
  svg.append(el('title', {}, 'Joint resistance over its reference, every estimate'));
  svg.append(axesGrid({ W, H, L, R, T, B, px, py, xt: { values: [], step: 1 }, yt }));
  const my = r2((T + H - B) / 2);
  svg.append(el('text', { x: 14, y: my, 'text-anchor': 'middle', class: 'axis-title', transform: `rotate(-90 14 ${my})` }, '× reference'));
  est.forEach((e, i) => {
    if (n <= 8 || i === 0 || i === n - 1) svg.append(el('text', { x: r2(px(i)), y: H - B + 18, 'text-anchor': 'middle', class: 'tick' }, formatTimestamp(e.estimated_at)));
  });
  for (const [ratio, cls] of [[l2, 'level2'], [l3, 'level3']]) {
    svg.append(el('line', { x1: L, x2: W - R, y1: r2(py(ratio)), y2: r2(py(ratio)), class: `limit ${cls}`, 'data-testid': `history-limit-${cls}`, 'data-ratio': ratio }));
    svg.append(el('text', { x: W - R + 6, y: r2(py(ratio)), dy: '0.35em', class: `tick limit-label ${cls}` }, `level ${cls.slice(-1)}`));
  }
  const legCount = est.length ? est[0].legs.length : 0;
  for (let k = 0; k < legCount; ++k) {
    const pts = est.map((e, i) => [px(i), py(e.legs[k].ratio)]);
    const g = el('g', { class: `leg-line leg-${(k % 6) + 1}`, 'data-testid': 'history-leg', 'data-leg': k + 1, 'data-points': pts.length });
    g.append(el('path', { d: pts.map(([x, y], i) => `${i ? 'L' : 'M'}${r2(x)},${r2(y)}`).join(''), class: 'leg-path' }));
    for (const [x, y] of pts) g.append(el('circle', { cx: r2(x), cy: r2(y), r: 3 }));
    const [lx, ly] = pts[pts.length - 1];
    g.append(el('text', { x: r2(lx + 6), y: r2(ly), dy: '0.35em', class: 'leg-label' }, `leg ${k + 1}`));
    svg.append(g);
  }
  return svg;
}

// ---------------------------------------------------------------- joint health: panel

let panelSeq = 0;

// Loads the panel of machineId: shown when the machine has servo records or stored estimates.
export async function loadJointHealth(machineId) {
  const seq = ++panelSeq;
  const panel = $('#joint-health');
  try {
    const [history, servo] = await Promise.all([api.jointHealth(machineId), api.measurements(machineId, { kind: 'servo', limit: 1 })]);
    if (seq !== panelSeq) return;
    panel.hidden = !history.estimates.length && !(servo.total > 0);
    panel.dataset.machineId = machineId;
    renderJointHealth(history);
  } catch (err) {
    if (seq !== panelSeq) return;
    if (err instanceof ApiError && err.status === 404) {
      panel.hidden = true;
      return;
    }
    if (!handleAuth(err)) $('#joint-current').replaceChildren(errorBox(err));
  }
}

export function resetJointHealth() {
  ++panelSeq;
  const panel = $('#joint-health');
  panel.hidden = true;
  delete panel.dataset.level;
  delete panel.dataset.estimates;
  $('#joint-current').replaceChildren();
  $('#joint-history').replaceChildren();
  setMessage($('#joint-status'), null);
}

function renderJointHealth(history) {
  const panel = $('#joint-health');
  const est = history.estimates;
  panel.dataset.estimates = String(est.length);
  if (!est.length) {
    delete panel.dataset.level;
    $('#joint-current').replaceChildren(h('p', { class: 'placeholder' }, 'No joint-health estimate yet: upload CW and CCW servo records and press “Estimate”.'));
    $('#joint-history').replaceChildren();
    return;
  }
  const newest = est[est.length - 1];
  panel.dataset.level = String(newest.level);
  const worst = newest.legs.filter((g) => g.level === newest.level && newest.level > 1).map((g) => `leg ${g.leg}`);
  $('#joint-current').replaceChildren(
    h(
      'p',
      { class: `joint-summary level-badge level-${newest.level}`, 'data-testid': 'joint-summary' },
      `Joint health ${levelWords(newest.level)}`,
      worst.length ? `: ${worst.join(', ')}` : '',
      ` (estimated ${formatTimestamp(newest.estimated_at)} from ${newest.measurement_ids.length} servo records, #${Math.min(...newest.measurement_ids)}–#${Math.max(...newest.measurement_ids)}; reference: ${newest.limits.reference_source}).`,
    ),
    h('figure', { class: 'chart-box' }, renderJointBars(newest)),
    jointTable(newest),
  );
  $('#joint-history').replaceChildren(h('h4', {}, 'History'), h('figure', { class: 'chart-box' }, renderJointHistory(history)));
}

// The servo records of the machine measured within a day of its newest one, and the newest
// stored estimate as the previous one (its growth is judged too).
async function estimateJointHealth() {
  const machineId = state.machineId;
  const status = $('#joint-status');
  const button = $('#joint-estimate');
  button.disabled = true;
  setMessage(status, 'info', 'Estimating the joint resistance…');
  try {
    const page = await api.measurements(machineId, { kind: 'servo', limit: 200, order: 'newest' });
    const items = page.items || [];
    if (!items.length) throw new Error('this machine has no servo records');
    const when = (m) => Date.parse(m.timestamp || m.uploaded_at);
    const newest = when(items[0]);
    const ids = items.filter((m) => newest - when(m) <= DAY_MS).map((m) => m.id);
    const body = { machine_id: machineId, measurement_ids: ids };
    const history = await api.jointHealth(machineId);
    const prev = history.estimates[history.estimates.length - 1];
    const sorted = (list) => [...list].sort((a, b) => a - b).join();
    if (prev && sorted(prev.measurement_ids) !== sorted(ids)) {
      body.previous = { legs: prev.legs.map((g) => ({ leg: g.leg, resistance_Nm: g.resistance_Nm })) };
    }
    const result = await api.servoJoints(body);
    if (state.machineId !== machineId) return;
    setMessage(status, 'success', `Estimated from ${ids.length} servo records: ${levelWords(result.level)}.`);
    await loadJointHealth(machineId);
  } catch (err) {
    if (!handleAuth(err)) setMessage(status, 'error', ...(refusalContent(err, 'estimate joint health') || problemContent(asProblem(err))));
  } finally {
    button.disabled = false;
  }
}

export function initServo() {
  $('#joint-estimate').addEventListener('click', () => estimateJointHealth());
}

// ---------------------------------------------------------------- strut forces of one record

// One chart a strut: the motor force measured and the machine model's (gravity, friction,
// inertia) over time; what differs is the external load and what the model lacks.
function strutChart(t, measured, model, strut) {
  const W = 440;
  const H = 200;
  const L = 62;
  const R = 10;
  const T = 24;
  const B = 38;
  const all = [...measured, ...model];
  let lo = Math.min(...all);
  let hi = Math.max(...all);
  const pad = (hi - lo) * 0.08 || 1;
  lo -= pad;
  hi += pad;
  const t0 = t[0];
  const t1 = t[t.length - 1];
  const px = (v) => L + ((v - t0) / (t1 - t0 || 1)) * (W - L - R);
  const py = (v) => T + (1 - (v - lo) / (hi - lo)) * (H - T - B);
  const svg = el('svg', { viewBox: `0 0 ${W} ${H}`, width: W, height: H, role: 'img', class: 'chart strut-force', 'data-testid': 'strut-force', 'data-strut': strut, 'aria-label': `Strut ${strut}: motor force measured and modelled over ${t.length} samples.` });
  svg.append(el('title', {}, `Strut ${strut} force`));
  svg.append(axesGrid({ W, H, L, R, T, B, px, py, xt: ticks(t0, t1, 5), yt: ticks(lo, hi, 4) }));
  svg.append(el('text', { x: L, y: 14, class: 'axis-title' }, `Strut ${strut} (N) against time (s)`));
  for (const [series, ys] of [['measured', measured], ['model', model]]) {
    const d = ys.map((y, i) => `${i ? 'L' : 'M'}${r2(px(t[i]))},${r2(py(y))}`).join('');
    svg.append(el('path', { d, class: `force-line ${series}`, 'data-series': series, 'data-points': ys.length }));
  }
  return svg;
}

// The force traces of a stored hexapod servo record (GET …/servo/force): each strut's measured
// and modelled motor force; a record the model cannot explain (no model, a feed drive) says why.
export async function renderServoForce(item, isCurrent) {
  const box = $('#polar-plot');
  box.replaceChildren(h('p', { class: 'placeholder' }, 'Loading the strut forces…'));
  $('#plot-note').textContent = '';
  let f;
  try {
    f = await api.servoForce(item.id);
  } catch (err) {
    if (!isCurrent()) return;
    if (handleAuth(err)) return;
    box.replaceChildren(h('div', { 'data-testid': 'servo-force-unavailable' }, h('p', {}, 'No force traces for this record:'), errorBox(err)));
    return;
  }
  if (!isCurrent()) return;
  const strut = (rows, j) => rows.map((r) => r[j]);
  const charts = [0, 1, 2, 3, 4, 5].map((j) => strutChart(f.t_s, strut(f.strut_force_N, j), strut(f.strut_model_N, j), j + 1));
  const legend = h('p', { class: 'note force-legend' }, h('span', { class: 'swatch measured' }), ' measured motor force  ', h('span', { class: 'swatch model' }), ` model (gravity, friction, inertia; machine version ${f.machine_version})`);
  box.replaceChildren(h('div', { class: 'servo-force', 'data-testid': 'servo-force-chart', 'data-samples': f.t_s.length }, legend, ...charts));
  $('#plot-note').textContent = `Mean external force at the tool tip: ${f.mean_force_N.map((v) => v.toFixed(1)).join(', ')} N (X, Y, Z).`;
}
