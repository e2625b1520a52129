// The fleet overview (#/fleet: every machine with its newest accuracy-audit level in colour and
// words, its newest measurement and its open jobs, from GET /api/v1/fleet) and a machine's
// trends (#/machines/{id}/trends?metric=…: one figure of its stored results over time, one series
// a test and direction (data-series), with the warn and stop limits of its audit rules, its rules
// on the change over time and the audit verdicts marked; by default the figure that set the
// machine's audit level). Every chart carries
// data-* attributes with the plotted numbers so what is drawn can be checked against the API.

import { ApiError, api } from './api.js';
import { handleAuth } from './auth.js';
import { axesGrid, chartWidth, el, r2, ticks } from './charts.js';
import { $, errorBox, h } from './dom.js';
import { auditWords, formatTimestamp } from './format.js';
import { machineAuditOrNull } from './audit.js';
import { machineHash, measurementHash, trendsHash } from './router.js';


// 404 (a route or a record not there): null.
const orNull = (promise) =>
  promise.catch((err) => {
    if (err instanceof ApiError && err.status === 404) return null;
    throw err;
  });

// ---------------------------------------------------------------- fleet

function auditCell(audit) {
  if (!audit) return h('span', { class: 'level-badge no-audit', 'data-testid': 'fleet-audit', 'data-level': 'none' }, 'no audit');
  return h(
    'span',
    { class: `level-badge level-${audit.level}`, 'data-testid': 'fleet-audit', 'data-level': audit.level },
    auditWords(audit.level),
    audit.created_at ? ` (${formatTimestamp(audit.created_at)})` : '',
  );
}

function lastCell(last) {
  if (!last) return 'none';
  return h('a', { href: measurementHash(last.id), 'data-testid': 'fleet-last' }, `${last.kind} #${last.id}, ${formatTimestamp(last.measured_at || last.uploaded_at)}`);
}

function fleetRow(m) {
  return h(
    'tr',
    { 'data-testid': 'fleet-machine', 'data-machine-id': m.machine_id },
    h('th', { scope: 'row' }, h('a', { href: machineHash(m.machine_id) }, m.machine_id)),
    h('td', {}, auditCell(m.audit)),
    h('td', {}, lastCell(m.last_measurement)),
    h('td', { class: 'num', 'data-key': 'measurements' }, String(m.measurements)),
    h('td', { class: 'num', 'data-key': 'open_jobs' }, String(m.open_jobs)),
    h('td', {}, h('a', { href: trendsHash(m.machine_id), 'data-testid': 'fleet-trends-link' }, 'trends')),
  );
}

export async function showFleet() {
  const box = $('#fleet-body');
  box.setAttribute('aria-busy', 'true');
  try {
    const fleet = await api.fleet();
    const machines = fleet.machines || [];
    $('#fleet-view').dataset.machines = String(machines.length);
    box.replaceChildren(
      machines.length
        ? h(
            'div',
            { class: 'joint-table-box' },
            h(
              'table',
              { class: 'figures fleet-table', 'data-testid': 'fleet-table' },
              h('thead', {}, h('tr', {}, ...['Machine', 'Accuracy audit', 'Last measurement', 'Measurements', 'Open jobs', ''].map((t) => h('th', { scope: 'col' }, t)))),
              h('tbody', {}, ...machines.map(fleetRow)),
            ),
          )
        : h('p', { class: 'placeholder' }, 'No machines yet.'),
    );
  } catch (err) {
    if (!handleAuth(err)) box.replaceChildren(errorBox(err));
  } finally {
    box.removeAttribute('aria-busy');
  }
}

// ---------------------------------------------------------------- trends

// The warn / stop limits of the machine's absolute audit rules for the metric (several rules:
// the tightest), or null; rules on the increase ("change") bound no value and are not drawn.
function limitsOf(audit, metric) {
  const rules = ((audit && audit.rules) || []).filter((r) => r.metric === metric && !r.change);
  if (!rules.length) return null;
  const pick = (k) => {
    const v = rules.map((r) => r[k]).filter((x) => typeof x === 'number');
    return v.length ? Math.min(...v) : null;
  };
  return { warn: pick('warn'), stop: pick('stop') };
}

// The evidence of a trend point or an audit finding: its measurement or, for a figure of the
// machine's hexapod calibrations, its calibration job; null when it names neither.
const isId = (v) => v !== undefined && v !== null;
function evidenceKey(x) {
  if (isId(x.job_id)) return `job ${x.job_id}`;
  return isId(x.measurement_id) ? `measurement ${x.measurement_id}` : null;
}

// evidence (evidenceKey) → the worst audit finding level on it for the metric.
function verdictsOf(audits, metric) {
  const out = new Map();
  for (const a of (audits && audits.audits) || []) {
    for (const f of a.findings || []) {
      const key = evidenceKey(f);
      if (f.metric !== metric || key === null) continue;
      out.set(key, Math.max(out.get(key) || 0, f.level));
    }
  }
  return out;
}

export function renderTrendChart(trend, limits, verdicts, W = 900) {
  const pts = trend.points.map((p) => ({ ...p, t: Date.parse(p.measured_at) }));
  const narrow = W < 600;
  const H = 340;
  const L = 64;
  const R = narrow ? 40 : 130;
  const T = 20;
  const B = 48;
  const values = pts.map((p) => p.value);
  for (const v of [limits?.warn, limits?.stop]) if (typeof v === 'number') values.push(v);
  const top = Math.max(...values, 0) * 1.1 || 1;
  const lo = Math.min(0, ...values);
  const t0 = Math.min(...pts.map((p) => p.t));
  const t1 = Math.max(...pts.map((p) => p.t));
  const px = (t) => L + (t1 > t0 ? (t - t0) / (t1 - t0) : 0.5) * (W - L - R);
  const py = (v) => T + (1 - (v - lo) / (top - lo)) * (H - T - B);
  const svg = el('svg', {
    viewBox: `0 0 ${W} ${H}`,
    width: W,
    height: H,
    role: 'img',
    class: 'chart trend',
    'data-testid': 'trend-chart',
    'data-points': pts.length,
    'aria-label': `${trend.label} (${trend.unit}) of ${trend.machine_id} over time, ${pts.length} points.`,
  });
  svg.append(el('title', {}, `${trend.label} over time`));
  svg.append(axesGrid({ W, H, L, R, T, B, px, py, xt: { values: [], step: 1 }, yt: ticks(lo, top, 5) }));
  const my = r2((T + H - B) / 2);
  svg.append(el('text', { x: 16, y: my, 'text-anchor': 'middle', class: 'axis-title', transform: `rotate(-90 16 ${my})` }, `${trend.metric} (${trend.unit})`));
  if (pts.length) {
    svg.append(el('text', { x: L, y: H - B + 18, class: 'tick' }, formatTimestamp(pts[0].measured_at)));
    svg.append(el('text', { x: W - R, y: H - B + 18, 'text-anchor': 'end', class: 'tick' }, formatTimestamp(pts[pts.length - 1].measured_at)));
  }
  for (const [key, cls] of [['warn', 'level2'], ['stop', 'level3']]) {
    const v = limits?.[key];
    if (typeof v !== 'number') continue;
    svg.append(el('line', { x1: L, x2: W - R, y1: r2(py(v)), y2: r2(py(v)), class: `limit ${cls}`, 'data-testid': `trend-limit-${key}`, 'data-value': v }));
    svg.append(el('text', { x: W - R + 6, y: r2(py(v)), dy: '0.35em', class: `tick limit-label ${cls}` }, key));
  }
  const groups = seriesOf(pts);
  groups.forEach((g, i) => {
    const series = el('g', { class: `trend-series series-${i % SERIES_COLOURS}`, 'data-series': g.key, 'data-testid': 'trend-series', 'data-points': g.points.length });
    series.append(el('path', { d: g.points.map((p, k) => `${k ? 'L' : 'M'}${r2(px(p.t))},${r2(py(p.value))}`).join(''), class: 'trend-line' }));
    for (const p of g.points) series.append(trendDot(p, trend, verdicts, px, py, g.key));
    svg.append(series);
  });
  if (!narrow && (groups.length > 1 || groups[0]?.key)) svg.append(legend(groups, W - R + 6, T + 40));
  return svg;
}

// One series a test and direction (a circle of one plane, radius and direction; one axis of a
// positioning run), oldest first; calibrations form one series without a name.
const SERIES_COLOURS = 6;
function seriesOf(pts) {
  const out = new Map();
  for (const p of pts) {
    const key = [p.test_id, p.direction ? String(p.direction).toUpperCase() : ''].filter(Boolean).join(' ');
    if (!out.has(key)) out.set(key, []);
    out.get(key).push(p);
  }
  return [...out.entries()].map(([key, points]) => ({ key, points: points.sort((a, b) => a.t - b.t) }));
}

function legend(groups, x, y) {
  const g = el('g', { class: 'trend-legend', 'data-testid': 'trend-legend' });
  groups.slice(0, 12).forEach((s, i) => {
    const row = el('g', { class: `series-${i % SERIES_COLOURS}`, transform: `translate(${x} ${y + i * 16})` });
    row.append(el('line', { x1: 0, x2: 12, y1: 0, y2: 0, class: 'trend-line' }));
    row.append(el('text', { x: 16, y: 0, dy: '0.35em', class: 'tick' }, s.key || 'all'));
    g.append(row);
  });
  return g;
}

function trendDot(p, trend, verdicts, px, py, series) {
  const level = verdicts.get(evidenceKey(p));
  const job = isId(p.job_id);
  const source = job ? { 'data-job-id': p.job_id } : { 'data-measurement-id': p.measurement_id };
  const dot = el('circle', { cx: r2(px(p.t)), cy: r2(py(p.value)), r: level ? 6 : 4, class: level ? `verdict level-${level}` : 'point', 'data-testid': 'trend-point', ...source, 'data-value': p.value, 'data-level': level || '', 'data-series': series });
  dot.append(el('title', {}, `${job ? `calibration job #${p.job_id}` : `#${p.measurement_id}`}${series ? ` (${series})` : ''}, ${formatTimestamp(p.measured_at)}: ${p.value.toFixed(2)} ${trend.unit}${level ? `, audit ${auditWords(level)}` : ''}`));
  return dot;
}

let metricsCache = null;

// The metric that set the machine's level: that of the worst finding of its newest audit, else
// of its first rule; null without an audit.
function levelMetric(audit, audits) {
  const newest = ((audits && audits.audits) || [])[0];
  const findings = ((newest && newest.findings) || []).slice().sort((a, b) => b.level - a.level);
  if (findings.length) return findings[0].metric;
  const rules = (audit && audit.rules) || [];
  return rules.length ? rules[0].metric : null;
}

// Without a metric in the address: the first of the kind of the machine's newest measurement.
async function defaultMetric(machineId) {
  const page = await api.measurements(machineId, { limit: 1, order: 'newest' });
  const kind = page.items && page.items.length ? page.items[0].kind : 'dbb';
  return (metricsCache.find((m) => m.kind === kind) || { metric: 'circularity_um' }).metric;
}

export async function showTrends(machineId, metric) {
  const view = $('#trends-view');
  view.dataset.machineId = machineId;
  $('#trends-heading').textContent = `Trends — ${machineId}`;
  const box = $('#trends-body');
  box.setAttribute('aria-busy', 'true');
  try {
    metricsCache = metricsCache || (await api.trendMetrics(machineId)).metrics;
    const [audit, audits] = await Promise.all([machineAuditOrNull(machineId), orNull(api.audits(machineId))]);
    const chosen = metric || levelMetric(audit, audits) || (await defaultMetric(machineId));
    const select = $('#trend-metric');
    select.replaceChildren(...metricsCache.map((m) => h('option', { value: m.metric }, `${m.kind}: ${m.metric} — ${m.label}`)));
    if (!metricsCache.some((m) => m.metric === chosen)) select.append(h('option', { value: chosen }, chosen));
    select.value = chosen;
    const trend = await api.trends(machineId, chosen);
    const groups = seriesOf(trend.points);
    const limits = limitsOf(audit, chosen);
    const changeRules = ((audit && audit.rules) || []).filter((r) => r.metric === chosen && r.change);
    const verdicts = verdictsOf(audits, chosen);
    view.dataset.metric = chosen;
    view.dataset.limits = limits ? 'rules' : 'none';
    box.replaceChildren(
      h('p', { class: 'note', 'data-testid': 'trend-note' }, trend.kind === 'calibration' ? `${trend.points.length} hexapod calibration${trend.points.length === 1 ? '' : 's'}. ` : `${trend.points.length} measurement${trend.points.length === 1 ? '' : 's'} of kind ${trend.kind}. `, limits ? 'Warn and stop limits from the machine’s audit rules.' : 'No audit rule for this figure: no limits drawn.', verdicts.size ? ` Larger points: audit findings (${[...new Set(verdicts.values())].sort().map(auditWords).join(', ')}).` : ''),
      trend.points.length ? h('figure', { class: 'chart-box chart-scroll' }, renderTrendChart(trend, limits, verdicts, chartWidth(box))) : h('p', { class: 'placeholder' }, 'No stored result has this figure yet.'),
      groups.length > 1 ? h('p', { class: 'note', 'data-testid': 'trend-series-list' }, `One line a test and direction: ${groups.map((g) => `${g.key || 'all'} (${g.points.length})`).join(', ')}.`) : '',
      changeRules.length ? h('p', { class: 'note', 'data-testid': 'trend-change-rules' }, 'Rules on the change over time: ', changeRules.map((r) => `increase ${r.change === 'days' ? `over ${r.days} days` : 'since the previous audit'}${typeof r.warn === 'number' ? `, warn above ${r.warn}` : ''}${typeof r.stop === 'number' ? `, stop above ${r.stop}` : ''} ${trend.unit}`).join('; '), '.') : '',
      limits ? h('p', { class: 'note' }, 'An audit judges the newest result of each rule’s kind; older points above a line were judged, if at all, when they were the newest.') : '',
    );
  } catch (err) {
    if (!handleAuth(err)) box.replaceChildren(errorBox(err));
  } finally {
    box.removeAttribute('aria-busy');
  }
}

export function initFleet() {
  $('#trend-metric').addEventListener('change', (e) => {
    const id = $('#trends-view').dataset.machineId;
    if (id) window.location.hash = trendsHash(id, e.target.value);
  });
}
