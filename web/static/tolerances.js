// Tolerances of the selected machine (docs/http.md "Tolerances and conformance"): the newest
// version of its table on the machine's page, an editor for engineers (a new version on save),
// and the conformance badges the measurement list and view show (pass, fail, undecided, no
// tolerance; per figure pass, fail, undecided, no value), with each figure's U and the decision
// rule that judged it (ISO 14253-1). Numbers typed are read by readNumberField (dom.js): "5,5" is
// 5.5, anything unreadable is refused naming the field and nothing is sent.

import { ApiError, apiFetch } from './api.js';
import { handleAuth } from './auth.js';
import { $, errorBox, h, problemContent, readNumberField, setMessage } from './dom.js';
import { formatNumber, formatTimestamp } from './format.js';
import { mayDo } from './roles.js';

const KINDS = ['dbb', 'straightness', 'flatness', 'parallelism', 'positioning', 'tracker'];
const VERDICT_WORDS = { pass: 'pass', fail: 'fail', undecided: 'undecided', 'no tolerance': 'no tolerance', 'no value': 'no value' };

const path = (machineId) => `/api/v1/machines/${encodeURIComponent(machineId)}/tolerances`;

// A badge of a verdict: the measurement's (pass | fail | no tolerance) or a figure's (pass |
// fail | no value); data-conformance carries the verdict for the browser scenarios.
export function conformanceBadge(conformance, testid = 'conformance-badge') {
  if (!conformance || typeof conformance !== 'object') return '';
  const verdict = String(conformance.verdict || '');
  const version = conformance.tolerance_version;
  const title = version ? `judged by tolerance table version ${version}` : 'the machine has no tolerance table';
  return h('span', { class: `badge conformance conformance-${verdict.replace(' ', '-')}`, 'data-testid': testid, 'data-conformance': verdict, title }, VERDICT_WORDS[verdict] || verdict);
}

function scopeText(e) {
  return [e.axis ? `axis ${e.axis}` : '', e.test_id ? `test ${e.test_id}` : '', e.direction ? e.direction.toUpperCase() : ''].filter(Boolean).join(', ') || 'every set-up';
}

// The conformance of one measurement with its figures, for the measurement's view.
export function conformancePanel(conformance) {
  if (!conformance) return h('div', { 'data-testid': 'conformance-panel', hidden: true });
  const figures = conformance.figures || [];
  const version = conformance.tolerance_version ? `tolerance table version ${conformance.tolerance_version}` : 'no tolerance table for this machine';
  return h(
    'div',
    { class: 'conformance-panel', 'data-testid': 'conformance-panel', 'data-conformance': conformance.verdict },
    h('p', {}, 'Conformance: ', conformanceBadge(conformance, 'conformance-verdict'), ` (${version})`),
    h('p', { class: 'muted small', 'data-testid': 'decision-rule' }, `Decision rule: ${(conformance.decision_rule && conformance.decision_rule.description) || 'simple acceptance: the value alone'}`),
    figures.length
      ? h(
          'table',
          { class: 'figures small', 'data-testid': 'conformance-figures' },
          h('thead', {}, h('tr', {}, ...['Figure', 'Tolerance of', 'Value', 'U (k = 2)', 'Tolerance', 'Verdict'].map((t) => h('th', {}, t)))),
          h(
            'tbody',
            {},
            ...figures.map((f) =>
              h(
                'tr',
                { 'data-metric': f.metric },
                h('td', {}, f.metric),
                h('td', {}, scopeText(f)),
                h('td', { class: 'num' }, typeof f.value === 'number' ? `${formatNumber(f.value, f.metric)} ${f.unit || ''}` : '—'),
                h('td', { class: 'num', 'data-testid': 'conformance-u' }, typeof f.U === 'number' ? `± ${formatNumber(f.U, f.metric)} ${f.unit || ''}` : 'not stated'),
                h('td', { class: 'num' }, `≤ ${formatNumber(f.tolerance, f.metric)} ${f.unit || ''}`),
                h('td', {}, conformanceBadge(f, 'conformance-figure')),
              ),
            ),
          ),
        )
      : '',
  );
}

async function loadTable(machineId) {
  try {
    return await apiFetch(path(machineId));
  } catch (err) {
    if (err instanceof ApiError && err.status === 404) return null;
    throw err;
  }
}

let metricsCache = null;
async function ownMetrics() {
  if (!metricsCache) metricsCache = apiFetch('/api/v1/audit-metrics').then((d) => (d.metrics || []).filter((m) => m.analysis === '' && KINDS.includes(m.kind)));
  return metricsCache;
}

// The panel below the machine's audit summary (made on first use).
function panel() {
  let box = $('#machine-tolerances');
  if (!box) {
    box = h('section', { id: 'machine-tolerances', class: 'tolerances-panel', 'data-testid': 'tolerances-panel' });
    $('#machine-audit-summary').after(box);
  }
  return box;
}

let seq = 0;
// Shows the machine's newest tolerance table, and the editor to an engineer.
export async function showTolerances(machineId) {
  const mine = ++seq;
  const box = panel();
  box.dataset.machineId = machineId;
  try {
    const [table, metrics] = await Promise.all([loadTable(machineId), mayDo('engineer') ? ownMetrics() : []]);
    if (mine !== seq) return;
    box.dataset.version = table ? String(table.version) : '';
    box.replaceChildren(
      h('h3', {}, 'Tolerances'),
      h('p', { class: 'note', 'data-testid': 'tolerances-version' }, table ? `Version ${table.version}, stored ${formatTimestamp(table.created_at)}; each measurement is judged against the newest version.` : 'No tolerance table: measurements are not judged.'),
      mayDo('engineer') ? editor(machineId, table, metrics) : entriesList(table),
    );
  } catch (err) {
    if (mine === seq && !handleAuth(err)) box.replaceChildren(errorBox(err));
  }
}

function entriesList(table) {
  const entries = table?.tolerances || [];
  if (!entries.length) return '';
  return h(
    'div',
    {},
    h('p', { class: 'note', 'data-testid': 'tolerances-rule' }, `Decision rule: ${table.decision_rule?.description || 'simple acceptance'}`),
    h('ul', { 'data-testid': 'tolerances-list' }, ...entries.map((e) => h('li', {}, `${e.kind} ${e.metric} ≤ ${e.tolerance} (${scopeText(e)})`))),
  );
}

// The decision rule of the table (ISO 14253-1): simple, guarded (w = U) or a guard band of w %.
function ruleEditor(table) {
  const rule = table?.decision_rule || { rule: 'simple' };
  const select = h(
    'select',
    { 'data-testid': 'tolerances-rule-select', 'data-key': 'decision_rule' },
    h('option', { value: 'simple' }, 'simple: the value alone'),
    h('option', { value: 'guarded' }, 'guarded: undecided within U of the tolerance'),
    h('option', { value: 'guard_band' }, 'guard band: undecided within w % of the tolerance'),
  );
  select.value = rule.rule || 'simple';
  const pct = h('input', { type: 'text', inputmode: 'decimal', 'data-key': 'guard_band_pct', 'data-testid': 'tolerances-guard-band', value: rule.guard_band_pct ?? '', placeholder: '10', size: 5 });
  const pctLabel = h('label', { class: 'tol-field' }, h('span', {}, 'w (% of the tolerance)'), pct);
  const sync = () => (pctLabel.hidden = select.value !== 'guard_band');
  select.addEventListener('change', sync);
  sync();
  return h('div', { class: 'tolerance-rule', 'data-testid': 'tolerance-rule' }, h('label', { class: 'tol-field' }, h('span', {}, 'Decision rule'), select), pctLabel);
}

function cell(row, key, control) {
  control.dataset.key = key;
  row.append(h('label', { class: 'tol-field' }, h('span', {}, key), control));
}

function entryRow(e = {}, listId) {
  const row = h('div', { class: 'tolerance-edit', 'data-testid': 'tolerance-edit' });
  const kind = h('select', {}, ...KINDS.map((k) => h('option', { value: k }, k)));
  kind.value = e.kind || 'dbb';
  cell(row, 'kind', kind);
  cell(row, 'metric', h('input', { type: 'text', list: listId, value: e.metric || '', placeholder: 'circular_deviation_um' }));
  cell(row, 'tolerance', h('input', { type: 'text', inputmode: 'decimal', value: e.tolerance ?? '', placeholder: '15' }));
  cell(row, 'test_id', h('input', { type: 'text', value: e.test_id || '', placeholder: 'xy-r150 or xy-*' }));
  const dir = h('select', {}, h('option', { value: '' }, 'either'), h('option', { value: 'cw' }, 'CW'), h('option', { value: 'ccw' }, 'CCW'));
  dir.value = e.direction || '';
  cell(row, 'direction', dir);
  cell(row, 'axis', h('input', { type: 'text', value: e.axis || '', placeholder: 'X', size: 4 }));
  row.append(h('button', { type: 'button', class: 'secondary', 'data-testid': 'tolerance-remove', onclick: () => row.remove() }, 'Remove'));
  return row;
}

function editor(machineId, table, metrics) {
  const listId = 'tolerance-metrics';
  const rows = h('div', { 'data-testid': 'tolerance-rows' }, ...(table?.tolerances || []).map((e) => entryRow(e, listId)));
  const status = h('p', { class: 'message', 'data-testid': 'tolerances-status', hidden: true });
  const form = h(
    'form',
    { class: 'tolerances-form', 'data-testid': 'tolerances-form', novalidate: true },
    h('datalist', { id: listId }, ...metrics.map((m) => h('option', { value: m.metric }, `${m.kind}: ${m.description} (${m.unit})`))),
    ruleEditor(table),
    rows,
    h('button', { type: 'button', class: 'secondary', 'data-testid': 'tolerance-add', onclick: () => rows.append(entryRow({}, listId)) }, 'Add tolerance'),
    h('button', { type: 'submit', 'data-testid': 'tolerances-save' }, 'Save tolerances'),
    status,
  );
  form.addEventListener('submit', (ev) => {
    ev.preventDefault();
    save(machineId, form, rows, status);
  });
  return form;
}

// The rows as a request body, or {error} naming the first field that cannot be read.
function readRows(rows) {
  const tolerances = [];
  const all = [...rows.querySelectorAll('[data-testid="tolerance-edit"]')];
  for (const [i, row] of all.entries()) {
    const get = (k) => row.querySelector(`[data-key="${k}"]`);
    const e = { kind: get('kind').value, metric: get('metric').value.trim() };
    if (!e.metric) return { error: `tolerances[${i}].metric: choose a metric.`, field: `tolerances[${i}].metric` };
    const t = readNumberField(get('tolerance'), `tolerances[${i}].tolerance`, { min: 0 });
    if (t.error) return { error: t.error, field: `tolerances[${i}].tolerance` };
    e.tolerance = t.value;
    for (const k of ['test_id', 'direction', 'axis']) if (get(k).value.trim()) e[k] = get(k).value.trim();
    tolerances.push(e);
  }
  return { body: { tolerances } };
}

// The form's decision rule, or {error} naming its field.
function readRule(form) {
  const rule = form.querySelector('[data-key="decision_rule"]').value;
  if (rule !== 'guard_band') return { value: rule };
  const w = readNumberField(form.querySelector('[data-key="guard_band_pct"]'), 'decision_rule.guard_band_pct', { min: 0 });
  if (w.error) return { error: w.error, field: 'decision_rule.guard_band_pct' };
  return { value: { rule, guard_band_pct: w.value } };
}

async function save(machineId, form, rows, status) {
  const read = readRows(rows);
  const rule = read.error ? {} : readRule(form);
  if (rule.error) Object.assign(read, rule);
  else if (!read.error) read.body.decision_rule = rule.value;
  if (read.error) {
    setMessage(status, 'error', ...problemContent({ title: 'Tolerances not saved', detail: read.error, field: read.field }));
    return;
  }
  try {
    const out = await apiFetch(path(machineId), { method: 'PUT', body: JSON.stringify(read.body), headers: { 'Content-Type': 'application/json' } });
    await showTolerances(machineId);
    const box = $('#machine-tolerances [data-testid="tolerances-status"]');
    if (box) setMessage(box, 'success', out.created ? `Saved as version ${out.version}.` : `Unchanged: version ${out.version} holds these tolerances.`);
    window.dispatchEvent(new CustomEvent('km-tolerances-changed', { detail: { machineId } }));
  } catch (err) {
    if (!handleAuth(err)) setMessage(status, 'error', ...problemContent(err instanceof ApiError ? err : { title: 'Tolerances not saved', detail: String(err.message || err) }));
  }
}

export function resetTolerances() {
  ++seq;
  $('#machine-tolerances')?.replaceChildren();
}
