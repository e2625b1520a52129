// The form of a machine's audit (audit.js): one row a rule (kind, metric, warn and stop in the
// metric's unit, what is compared, days, and the set-ups it is scoped to: a test_id or a pattern
// with *, the direction of a DBB test, the axis of a positioning test), then the audit's schedule,
// the age beyond which a set-up's newest test is stale and what a stale set-up gives. Checked here
// as the API checks it (docs/http.md: a known kind and metric, warn / stop finite and ≥ 0, at
// least one, warn ≤ stop, days 1–3660, max_age_days 1–3660) so a mistake is named with its field
// (rules[2].warn) before anything is sent. Numbers are read by readNumberField ("5,5" is 5.5).

import { $, $$, h, readNumberField } from './dom.js';
import { displayUnit } from './format.js';

const MAX_RULES = 200;
export const DEFAULT_MAX_AGE_DAYS = 365;

function kindsOf(metrics) {
  return [...new Set(metrics.map((m) => m.kind))];
}

// The unit of a metric as GET /api/v1/audit-metrics gives it ("µm", "level", "1"); a metric with
// an axis (accuracy_um.X) or an effect (diagnosis.backlash_x) has the unit of its family.
export function metricUnit(metrics, kind, metric) {
  const name = String(metric || '');
  const base = name.replace(/^diagnosis\..*/, 'diagnosis.<effect>').replace(/\.[A-Z][A-Z0-9]*$/, '');
  const m = metrics.find((x) => x.kind === kind && (x.metric === name || x.metric === base));
  if (!m || !m.unit) return '';
  return m.unit === '1' ? 'ratio' : displayUnit(m.unit);
}

// The metric names offered for a kind (a placeholder such as diagnosis.<effect> is typed in full).
function datalists(metrics) {
  return kindsOf(metrics).map((k) => h('datalist', { id: `audit-metrics-${k}` }, ...metrics.filter((m) => m.kind === k).map((m) => h('option', { value: m.metric }, `${m.description} (${m.unit})`))));
}

const numberText = (v) => (typeof v === 'number' && Number.isFinite(v) ? String(v) : '');
const numberInput = (key, label, v) => h('input', { type: 'text', inputmode: 'decimal', autocomplete: 'off', spellcheck: 'false', class: 'number', 'data-key': key, 'aria-label': label, value: numberText(v) });

function ruleRow(rule, metrics) {
  const kinds = kindsOf(metrics);
  const kind = h('select', { 'data-key': 'kind', 'aria-label': 'Kind' }, ...kinds.map((k) => h('option', { value: k }, k)));
  kind.value = rule.kind && kinds.includes(rule.kind) ? rule.kind : kinds[0] || 'dbb';
  const metric = h('input', { type: 'text', 'data-key': 'metric', 'aria-label': 'Metric', spellcheck: 'false', list: `audit-metrics-${kind.value}`, value: rule.metric || '' });
  const units = [h('span', { class: 'unit', 'data-testid': 'audit-unit', 'data-for': 'warn' }), h('span', { class: 'unit', 'data-testid': 'audit-unit', 'data-for': 'stop' })];
  const change = h('select', { 'data-key': 'change', 'aria-label': 'Compared value' }, h('option', { value: '' }, 'the newest value'), h('option', { value: 'previous_audit' }, 'its increase since the previous audit'), h('option', { value: 'days' }, 'its increase over N days'));
  change.value = rule.change || '';
  const days = h('input', { type: 'text', inputmode: 'numeric', autocomplete: 'off', class: 'number', 'data-key': 'days', 'aria-label': 'Days', value: rule.days ? String(rule.days) : '' });
  const testId = h('input', { type: 'text', 'data-key': 'test_id', 'aria-label': 'Test (test_id or pattern with *)', spellcheck: 'false', placeholder: 'every test', value: rule.test_id || '' });
  const direction = h('select', { 'data-key': 'direction', 'aria-label': 'Direction' }, h('option', { value: '' }, 'both'), h('option', { value: 'ccw' }, 'CCW'), h('option', { value: 'cw' }, 'CW'));
  direction.value = rule.direction === 'cw' || rule.direction === 'ccw' ? rule.direction : '';
  const axis = h('input', { type: 'text', 'data-key': 'axis', 'aria-label': 'Axis', spellcheck: 'false', placeholder: 'every axis', size: 6, value: rule.axis || '' });
  const directionLabel = h('label', { class: 'scope-dbb' }, 'Direction ', direction);
  const axisLabel = h('label', { class: 'scope-positioning' }, 'Axis ', axis);
  const follow = () => {
    metric.setAttribute('list', `audit-metrics-${kind.value}`);
    const unit = metricUnit(metrics, kind.value, metric.value.trim());
    for (const u of units) u.textContent = unit || '(unit of the metric)';
    directionLabel.hidden = kind.value !== 'dbb';
    axisLabel.hidden = kind.value !== 'positioning';
  };
  kind.addEventListener('change', follow);
  metric.addEventListener('input', follow);
  const row = h(
    'fieldset',
    { class: 'audit-rule-edit', 'data-testid': 'audit-rule-edit' },
    h('legend', {}, 'Rule'),
    h('label', {}, 'Kind ', kind),
    h('label', {}, 'Metric ', metric),
    h('label', {}, 'Warn ', h('span', { class: 'with-unit' }, numberInput('warn', 'Warn limit', rule.warn), units[0])),
    h('label', {}, 'Stop ', h('span', { class: 'with-unit' }, numberInput('stop', 'Stop limit', rule.stop), units[1])),
    h('label', {}, 'Compare ', change),
    h('label', {}, 'Days ', days),
    h('label', {}, 'Test ', testId),
    directionLabel,
    axisLabel,
    h('button', { type: 'button', class: 'secondary small', 'data-testid': 'audit-remove-rule', onclick: () => { row.remove(); renumber(); } }, 'Remove'),
  );
  follow();
  return row;
}

function renumber() {
  $$('#audit-rules-edit [data-testid="audit-rule-edit"]').forEach((row, i) => {
    row.dataset.index = String(i);
    row.querySelector('legend').textContent = `Rule ${i + 1}`;
  });
}

let currentMetrics = [];

// Fills the form with the stored audit (or one empty rule when there is none).
export function ruleEditor(audit, metrics) {
  currentMetrics = metrics;
  const box = $('#audit-rules-edit');
  const rules = (audit && audit.rules) || [];
  box.replaceChildren(...datalists(metrics), ...(rules.length ? rules : [{ kind: 'dbb', metric: 'circularity_um' }]).map((r) => ruleRow(r, metrics)));
  renumber();
  $('#audit-schedule').value = (audit && audit.schedule) || '';
  $('#audit-max-age').value = audit && Number.isInteger(audit.max_age_days) ? String(audit.max_age_days) : String(DEFAULT_MAX_AGE_DAYS);
  $('#audit-stale').value = audit && audit.stale === 'warn' ? 'warn' : 'ignore';
  $('#audit-instrument').value = audit && audit.instrument_overdue === 'warn' ? 'warn' : 'ignore';
  const rule = audit?.decision_rule || {};
  $('#audit-decision-rule').value = ['guarded', 'guard_band'].includes(rule.rule) ? rule.rule : 'simple';
  $('#audit-guard-band').value = rule.guard_band_pct ?? '';
  $('#audit-form-status').hidden = true;
  const add = $('#audit-add-rule');
  add.onclick = () => {
    if ($$('#audit-rules-edit [data-testid="audit-rule-edit"]').length >= MAX_RULES) return;
    box.append(ruleRow({ kind: 'dbb', metric: '' }, currentMetrics));
    renumber();
  };
}

function knownMetric(metrics, kind, metric) {
  return metrics.some((m) => {
    if (m.kind !== kind) return false;
    if (m.metric === metric) return true;
    if (m.metric.includes('<')) {
      const prefix = m.metric.slice(0, m.metric.indexOf('<'));
      return metric.startsWith(prefix) && metric.length > prefix.length;
    }
    return metric.startsWith(`${m.metric}.`) && /^[A-Z][A-Z0-9]{0,7}$/.test(metric.slice(m.metric.length + 1));
  });
}

// One row → {rule} or {error: {field, detail}} (its input marked aria-invalid and focused).
function readRule(row, i, metrics) {
  const get = (k) => row.querySelector(`[data-key="${k}"]`);
  const fail = (k, detail) => {
    get(k).setAttribute('aria-invalid', 'true');
    get(k).focus();
    return { error: { field: `rules[${i}].${k}`, detail: `Rule ${i + 1}: ${detail}` } };
  };
  const rule = { kind: get('kind').value, metric: get('metric').value.trim() };
  if (!rule.metric) return fail('metric', 'choose the figure it limits.');
  if (!knownMetric(metrics, rule.kind, rule.metric)) return fail('metric', `“${rule.metric}” is not a ${rule.kind} metric of the audits.`);
  for (const k of ['warn', 'stop']) {
    const r = readNumberField(get(k), `the ${k} limit`, { min: 0, optional: true });
    if (r.error) return fail(k, `${r.error}.`);
    if (!r.empty) rule[k] = r.value;
  }
  if (rule.warn === undefined && rule.stop === undefined) return fail('warn', 'give a warn or a stop limit (or both).');
  if (rule.warn !== undefined && rule.stop !== undefined && rule.warn > rule.stop) return fail('warn', `the warn limit ${rule.warn} is above the stop limit ${rule.stop}.`);
  const change = get('change').value;
  if (change) rule.change = change;
  if (change === 'days') {
    const r = readNumberField(get('days'), 'the number of days', { min: 1, max: 3660, integer: true });
    if (r.error) return fail('days', `${r.error} (a whole number from 1 to 3660).`);
    rule.days = r.value;
  }
  const testId = get('test_id').value.trim();
  if (testId) rule.test_id = testId;
  if (rule.kind === 'dbb' && get('direction').value) rule.direction = get('direction').value;
  if (rule.kind === 'positioning') {
    const axis = get('axis').value.trim().toUpperCase();
    if (axis && !/^[A-Z][A-Z0-9]{0,7}$/.test(axis)) return fail('axis', `“${get('axis').value.trim()}” is not an axis name (a letter, then letters or digits, e.g. X or A1).`);
    if (axis) rule.axis = axis;
  }
  return { rule };
}

// Reads the form: {body: {schedule, rules, max_age_days?, stale?, decision_rule?}} or {error: {field, detail}} for
// the first mistake (its input is marked aria-invalid).
export function checkRules(metrics) {
  $$('#audit-form [aria-invalid]').forEach((n) => n.removeAttribute('aria-invalid'));
  const rows = $$('#audit-rules-edit [data-testid="audit-rule-edit"]');
  const rules = [];
  for (const [i, row] of rows.entries()) {
    const r = readRule(row, i, metrics);
    if (r.error) return r;
    rules.push(r.rule);
  }
  const age = readNumberField($('#audit-max-age'), 'the age of a stale set-up', { min: 1, max: 3660, integer: true });
  if (age.error) {
    $('#audit-max-age').focus();
    return { error: { field: 'max_age_days', detail: `${age.error} (a whole number of days from 1 to 3660).` } };
  }
  const schedule = $('#audit-schedule').value.trim();
  const body = { schedule: schedule || null, rules };
  // A PUT replaces the audit: a key left out is its default (365 days, stale set-ups ignored).
  if (age.value !== DEFAULT_MAX_AGE_DAYS) body.max_age_days = age.value;
  if ($('#audit-stale').value === 'warn') body.stale = 'warn';
  if ($('#audit-instrument').value === 'warn') body.instrument_overdue = 'warn';
  const rule = $('#audit-decision-rule').value;
  if (rule === 'guarded') body.decision_rule = 'guarded';
  if (rule === 'guard_band') {
    const w = readNumberField($('#audit-guard-band'), 'the guard band', { min: 0, max: 100 });
    if (w.error || w.value <= 0) {
      $('#audit-guard-band').focus();
      return { error: { field: 'decision_rule.guard_band_pct', detail: `${w.error || 'must be more than 0'} (w in % of the limit, more than 0 and at most 100).` } };
    }
    body.decision_rule = { rule, guard_band_pct: w.value };
  }
  return { body };
}
