// The form of a machine's audit rules and schedule (audit.js): one row a rule (kind, metric, warn,
// stop, what is compared, days), checked here as the API checks a rule (docs/http.md: a known
// kind and metric, warn / stop finite and ≥ 0, at least one, warn ≤ stop, days 1–3660 for a
// rule over days) so a mistake is named with its field (rules[2].warn) before anything is sent.

import { $, $$, h } from './dom.js';

const MAX_RULES = 200;

function kindsOf(metrics) {
  return [...new Set(metrics.map((m) => m.kind))];
}

// The metric names offered for a kind (a placeholder such as diagnosis.<effect> is typed in full).
function datalists(metrics) {
  return kindsOf(metrics).map((k) => h('datalist', { id: `audit-metrics-${k}` }, ...metrics.filter((m) => m.kind === k).map((m) => h('option', { value: m.metric }, `${m.description} (${m.unit})`))));
}

function ruleRow(rule, metrics) {
  const kinds = kindsOf(metrics);
  const kind = h('select', { 'data-key': 'kind', 'aria-label': 'Kind' }, ...kinds.map((k) => h('option', { value: k }, k)));
  kind.value = rule.kind && kinds.includes(rule.kind) ? rule.kind : kinds[0] || 'dbb';
  const metric = h('input', { type: 'text', 'data-key': 'metric', 'aria-label': 'Metric', spellcheck: 'false', list: `audit-metrics-${kind.value}`, value: rule.metric || '' });
  kind.addEventListener('change', () => metric.setAttribute('list', `audit-metrics-${kind.value}`));
  const numberInput = (key, label, v) => h('input', { type: 'number', step: 'any', min: '0', 'data-key': key, 'aria-label': label, value: typeof v === 'number' ? String(v) : '' });
  const change = h('select', { 'data-key': 'change', 'aria-label': 'Compared value' }, h('option', { value: '' }, 'the newest value'), h('option', { value: 'previous_audit' }, 'its increase since the previous audit'), h('option', { value: 'days' }, 'its increase over N days'));
  change.value = rule.change || '';
  const days = h('input', { type: 'number', min: '1', max: '3660', step: '1', 'data-key': 'days', 'aria-label': 'Days', value: rule.days ? String(rule.days) : '' });
  const row = h(
    'fieldset',
    { class: 'audit-rule-edit', 'data-testid': 'audit-rule-edit' },
    h('legend', {}, 'Rule'),
    h('label', {}, 'Kind ', kind),
    h('label', {}, 'Metric ', metric),
    h('label', {}, 'Warn ', numberInput('warn', 'Warn limit', rule.warn)),
    h('label', {}, 'Stop ', numberInput('stop', 'Stop limit', rule.stop)),
    h('label', {}, 'Compare ', change),
    h('label', {}, 'Days ', days),
    h('button', { type: 'button', class: 'secondary small', 'data-testid': 'audit-remove-rule', onclick: () => { row.remove(); renumber(); } }, 'Remove'),
  );
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

// Reads the rows: {body: {schedule, rules}} or {error: {field, detail}} for the first mistake
// (its input is marked aria-invalid).
export function checkRules(metrics) {
  $$('#audit-form [aria-invalid]').forEach((n) => n.removeAttribute('aria-invalid'));
  const rows = $$('#audit-rules-edit [data-testid="audit-rule-edit"]');
  const rules = [];
  for (const [i, row] of rows.entries()) {
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
      const text = get(k).value.trim();
      if (text === '') continue;
      const v = Number(text);
      if (!Number.isFinite(v) || v < 0) return fail(k, `the ${k} limit must be a number ≥ 0.`);
      rule[k] = v;
    }
    if (rule.warn === undefined && rule.stop === undefined) return fail('warn', 'give a warn or a stop limit (or both).');
    if (rule.warn !== undefined && rule.stop !== undefined && rule.warn > rule.stop) return fail('warn', `the warn limit ${rule.warn} is above the stop limit ${rule.stop}.`);
    const change = get('change').value;
    if (change) rule.change = change;
    if (change === 'days') {
      const d = Number(get('days').value);
      if (!Number.isInteger(d) || d < 1 || d > 3660) return fail('days', 'the number of days must be a whole number from 1 to 3660.');
      rule.days = d;
    }
    rules.push(rule);
  }
  const schedule = $('#audit-schedule').value.trim();
  return { body: { schedule: schedule || null, rules } };
}
