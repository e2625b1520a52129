// A machine's accuracy audit (#/machines/{id}/audit): the level of its newest verdict, one row a
// rule with its warn / stop limits and what the newest audit found, each finding linked to the
// measurement (or calibration job) it came from, which of two tests of the same moment a rule
// judged and why, the history of verdicts, and the rules and schedule as a form an engineer
// edits (checked here as the API checks them, the API's answer shown when it refuses). The same
// level, rules and findings appear in short beside a machine's measurement list.
// Data attributes: data-audit-level (1–3, or none), data-audit-rule (the rule's index),
// data-finding-measurement / data-finding-job (the evidence of a finding).

import { ApiError, api } from './api.js';
import { handleAuth } from './auth.js';
import { $, asProblem, errorBox, h, problemContent, setMessage } from './dom.js';
import { auditWords, formatDirection, formatTimestamp, plural } from './format.js';
import { auditHash, jobHash, measurementHash, trendsHash } from './router.js';
import { hideCertificate, showAuditCertificate } from './reports.js';
import { refusalContent } from './roles.js';
import { checkRules, DEFAULT_MAX_AGE_DAYS, metricUnit, ruleEditor } from './audit_form.js';
import { state } from './state.js';

// 404 (no audit stored): null.
const orNull = (promise) =>
  promise.catch((err) => {
    if (err instanceof ApiError && err.status === 404) return null;
    throw err;
  });

// The machine's rules and schedule, or null when it has none. GET /api/v1/machines says how many
// rules each machine has now (another user may have set them since the list was loaded), so a
// machine without an audit costs no failed request.
export async function machineAuditOrNull(machineId) {
  const list = await api.machines();
  const fresh = (list.machines || []).find((x) => x.machine_id === machineId);
  const m = state.machines.find((x) => x.machine_id === machineId);
  if (fresh && m) m.audit_rules = fresh.audit_rules;
  if (fresh && fresh.audit_rules === 0) return null;
  return orNull(api.machineAudit(machineId));
}

function noteRuleCount(machineId, n) {
  const m = state.machines.find((x) => x.machine_id === machineId);
  if (m) m.audit_rules = n;
}

let metricsCache = null;
export async function auditMetricList() {
  if (!metricsCache) metricsCache = (await api.auditMetrics()).metrics || [];
  return metricsCache;
}

const num = (v) => (typeof v === 'number' && Number.isFinite(v) ? v : null);
const fmt = (v) => (num(v) === null ? '—' : Number(v.toFixed(3)).toString());
const unitOfMetric = metricUnit;

// The set-up of a finding, a checked entry or a stale entry in words: the server's name for it
// ("xy-r150 CW", "axis X"), else its test and direction.
function setUpText(x) {
  if (x.set_up) return String(x.set_up);
  const parts = [x.test_id, x.direction ? formatDirection(x.direction) : ''].filter(Boolean);
  return parts.join(' ');
}

// A rule's scope in words: "tests xy-*, CW", "axis X"; '' for every set-up of its kind.
function scopeText(rule) {
  const parts = [];
  if (rule.test_id) parts.push(`${String(rule.test_id).includes('*') ? 'tests' : 'test'} ${rule.test_id}`);
  if (rule.direction) parts.push(formatDirection(rule.direction));
  if (rule.axis) parts.push(`axis ${rule.axis}`);
  return parts.join(', ');
}

// The worst of a rule's checked entries (one a set-up): a finding of the highest level, else a
// value within limits (the largest), else one not evaluated.
function worstOf(entries) {
  const rank = (c) => (c.status === 'finding' ? 10 + (c.level || 0) : c.status === 'ok' || c.status === 'stale' ? 1 : 0);
  return [...entries].sort((a, b) => rank(b) - rank(a) || (num(b.value) ?? -Infinity) - (num(a.value) ?? -Infinity))[0] || null;
}

export function levelBadge(verdict, testid = 'audit-level') {
  if (!verdict) return h('span', { class: 'level-badge no-audit', 'data-testid': testid, 'data-audit-level': 'none' }, 'no audit run yet');
  return h('span', { class: `level-badge level-${verdict.level}`, 'data-testid': testid, 'data-audit-level': verdict.level }, auditWords(verdict.level));
}

// The evidence of a finding or a checked rule: a link to its measurement or calibration job.
function evidenceLink(x, attr) {
  if (x.job_id !== undefined && x.job_id !== null) return h('a', { href: jobHash(x.job_id), [`data-${attr}-job`]: x.job_id }, `calibration job #${x.job_id}`);
  if (x.measurement_id === undefined || x.measurement_id === null) return '';
  return h('a', { href: measurementHash(x.measurement_id), [`data-${attr}-measurement`]: x.measurement_id }, `measurement #${x.measurement_id}`);
}

function limitsText(rule, unit) {
  const parts = [];
  if (num(rule.warn) !== null) parts.push(`warn ${fmt(rule.warn)}`);
  if (num(rule.stop) !== null) parts.push(`stop ${fmt(rule.stop)}`);
  const u = unit ? ` ${unit}` : '';
  if (rule.change === 'previous_audit') return `increase since the previous audit: ${parts.join(', ')}${u}`;
  if (rule.change === 'days') return `increase over ${plural(rule.days, 'day')}: ${parts.join(', ')}${u}`;
  return `${parts.join(', ')}${u}`;
}

function statusText(c) {
  if (!c) return 'not judged yet';
  if (c.status === 'finding') return auditWords(c.level);
  if (c.status === 'ok') return 'within limits';
  if (c.status === 'stale') return `stale: newest test of ${formatTimestamp(c.measured_at)}`;
  return `not evaluated${c.reason ? `: ${c.reason}` : ''}`;
}

function ruleRow(rule, index, checked, metrics, pairNotes, compact) {
  const unit = unitOfMetric(metrics, rule.kind, rule.metric);
  const entries = (checked || []).filter((x) => x.rule === index);
  const c = worstOf(entries);
  const scope = scopeText(rule);
  const where = c && entries.length > 1 && setUpText(c) ? ` (${setUpText(c)}, the worst of ${plural(entries.length, 'set-up')})` : c && setUpText(c) ? ` (${setUpText(c)})` : '';
  const cells = [
    h('th', { scope: 'row' }, `${rule.kind} ${rule.metric}`, scope ? h('span', { class: 'rule-scope', 'data-testid': 'audit-rule-scope' }, ` — ${scope}`) : ''),
    h('td', {}, limitsText(rule, unit)),
    h('td', { class: 'num', 'data-key': 'value' }, c && num(c.value) !== null ? `${fmt(c.value)} ${unit}` : '—'),
    h('td', { 'data-key': 'status' }, statusText(c), where),
  ];
  if (!compact) cells.push(h('td', {}, c ? evidenceLink(c, 'judged') : '', pairNotes.get(index) ? h('p', { class: 'note pair-judged', 'data-testid': 'audit-pair-note' }, pairNotes.get(index)) : ''));
  return h('tr', { 'data-audit-rule': index, 'data-status': c ? c.status : 'none', 'data-level': c && c.level ? c.level : '' }, ...cells);
}

function rulesTable(audit, verdict, metrics, pairNotes, compact = false) {
  const rules = (audit && audit.rules) || [];
  if (!rules.length) return h('p', { class: 'placeholder', 'data-testid': 'audit-no-rules' }, 'No rules set for this machine yet.');
  const head = ['Rule', 'Limits', 'Newest value', 'Status'];
  if (!compact) head.push('Judged result');
  return h(
    'div',
    { class: 'table-scroll' },
    h(
      'table',
      { class: 'figures audit-rules', 'data-testid': 'audit-rules' },
      h('thead', {}, h('tr', {}, ...head.map((t) => h('th', { scope: 'col' }, t)))),
      h('tbody', {}, ...rules.map((r, i) => ruleRow(r, i, verdict && verdict.checked, metrics, pairNotes, compact))),
    ),
  );
}

function findingsList(verdict) {
  const findings = (verdict && verdict.findings) || [];
  if (!findings.length) return h('p', { class: 'note', 'data-testid': 'audit-no-findings' }, verdict ? 'No findings: every evaluated rule is within its limits.' : '');
  const rule = verdict.decision_rule?.description;
  return h(
    'ul',
    { class: 'findings', 'data-testid': 'audit-findings', title: rule ? `Decision rule: ${rule}` : '' },
    ...findings.map((f) =>
      h(
        'li',
        { class: `finding level-${f.level}`, 'data-testid': 'audit-finding', 'data-set-up': setUpText(f), 'data-decision': f.decision || '' },
        h('span', { class: `level-badge level-${f.level}` }, auditWords(f.level)),
        ' ',
        f.message || `${f.kind} ${f.metric} ${fmt(f.value)}`,
        ' — ',
        setUpText(f) ? h('span', { class: 'set-up', 'data-testid': 'audit-finding-setup' }, `set-up ${setUpText(f)}, `) : '',
        evidenceLink(f, 'finding'),
        f.measured_at ? ` measured ${formatTimestamp(f.measured_at)}` : '',
      ),
    ),
  );
}

// Every set-up the newest audit judged: one row a rule and set-up, with its value, status and the
// measurement judged (data-checked-rule, data-checked-measurement).
function checkedTable(verdict, rules, metrics) {
  const checked = (verdict && verdict.checked) || [];
  if (!checked.length) return '';
  return h(
    'div',
    { class: 'table-scroll' },
    h(
      'table',
      { class: 'figures audit-checked', 'data-testid': 'audit-checked' },
      h('thead', {}, h('tr', {}, ...['Rule', 'Set-up', 'Value', 'Status', 'Measurement'].map((t) => h('th', { scope: 'col' }, t)))),
      h(
        'tbody',
        {},
        ...checked.map((c) => {
          const unit = unitOfMetric(metrics, c.kind, c.metric);
          return h(
            'tr',
            { 'data-checked-rule': c.rule, 'data-status': c.status, 'data-set-up': setUpText(c), 'data-level': c.level || '' },
            h('td', {}, `${Number.isInteger(c.rule) ? `${c.rule + 1}. ` : ''}${c.kind} ${c.metric}`),
            h('td', { 'data-key': 'set_up' }, setUpText(c) || '—'),
            h('td', { class: 'num', 'data-key': 'value' }, num(c.value) !== null ? `${fmt(c.value)} ${unit}` : '—'),
            h('td', { 'data-key': 'status' }, statusText(c)),
            h('td', { 'data-key': 'measurement' }, evidenceLink(c, 'checked'), c.measured_at ? ` measured ${formatTimestamp(c.measured_at)}` : ''),
          );
        }),
      ),
    ),
  );
}

// The set-ups whose newest test is older than the audit's max_age_days, with its date.
function staleList(verdict, audit) {
  const stale = (verdict && verdict.stale) || [];
  if (!stale.length) return '';
  const days = audit && Number.isInteger(audit.max_age_days) ? audit.max_age_days : DEFAULT_MAX_AGE_DAYS;
  const warns = audit && audit.stale === 'warn';
  return h(
    'div',
    { class: 'audit-stale', 'data-testid': 'audit-stale' },
    h('h3', {}, 'Stale set-ups'),
    h('p', { class: 'note' }, `Their newest test is older than ${plural(days, 'day')}: measure them again. ${warns ? 'The audit counts each as a level-2 finding.' : 'The audit lists them without a finding.'}`),
    h(
      'ul',
      { class: 'findings' },
      ...stale.map((x) =>
        h(
          'li',
          { 'data-testid': 'audit-stale-item', 'data-set-up': setUpText(x), 'data-measurement-id': x.measurement_id ?? '' },
          `${x.kind ? `${x.kind} ` : ''}${setUpText(x) || 'set-up'}: newest test `,
          evidenceLink(x, 'stale'),
          x.measured_at ? ` measured ${formatTimestamp(x.measured_at)}` : '',
        ),
      ),
    ),
  );
}

function historyTable(verdicts) {
  if (!verdicts.length) return h('p', { class: 'note' }, 'No audit has run yet.');
  return h(
    'div',
    { class: 'table-scroll' },
    h(
      'table',
      { class: 'figures audit-history', 'data-testid': 'audit-history' },
      h('thead', {}, h('tr', {}, ...['When', 'Trigger', 'Level', 'Findings'].map((t) => h('th', { scope: 'col' }, t)))),
      h(
        'tbody',
        {},
        ...verdicts.map((v) =>
          h(
            'tr',
            { 'data-audit-id': v.id, 'data-level': v.level },
            h('td', {}, formatTimestamp(v.created_at)),
            h('td', {}, v.trigger === 'schedule' ? 'scheduled' : 'on request'),
            h('td', {}, h('span', { class: `level-badge level-${v.level}` }, auditWords(v.level))),
            h('td', {}, (v.findings || []).map((f) => `${f.kind} ${f.metric}${setUpText(f) ? ` ${setUpText(f)}` : ''} ${fmt(f.value)} (${auditWords(f.level)})`).join('; ') || 'none'),
          ),
        ),
      ),
    ),
  );
}

// For each DBB rule judged on a test with an opposite-direction partner measured within an hour,
// one sentence: which test the rule judged, its value and the partner's, and why that one.
// A verdict that judges every set-up (its checked entries name them) judged both tests: the note
// says so, the worse first.
function setUpPairNotes(verdict, metrics) {
  const notes = new Map();
  const checked = ((verdict && verdict.checked) || []).filter((c) => c.kind === 'dbb' && !c.change && num(c.value) !== null && c.measurement_id !== undefined && c.direction);
  for (const c of checked) {
    if (notes.has(c.rule)) continue;
    const partner = checked.find((p) => p.rule === c.rule && p.test_id === c.test_id && p.direction !== c.direction);
    if (!partner) continue;
    const [a, b] = worstOf([c, partner]) === c ? [c, partner] : [partner, c];
    const unit = unitOfMetric(metrics, 'dbb', c.metric);
    notes.set(
      c.rule,
      `Judged: the ${formatDirection(a.direction)} test #${a.measurement_id} (${fmt(a.value)} ${unit}) and its ${formatDirection(b.direction)} partner #${b.measurement_id} (${fmt(b.value)} ${unit}), each the newest test of its set-up (${setUpText(a)}; ${setUpText(b)}); the rule's status is the worse of the two.`,
    );
  }
  return notes;
}

async function pairNotesOf(machineId, verdict, metrics) {
  if (((verdict && verdict.checked) || []).some((c) => c.set_up !== undefined)) return setUpPairNotes(verdict, metrics);
  const notes = new Map();
  const checked = ((verdict && verdict.checked) || []).filter((c) => c.kind === 'dbb' && !c.change && num(c.value) !== null && c.measurement_id !== undefined && c.metric !== 'circular_hysteresis_um');
  for (const c of checked.slice(0, 4)) {
    const trend = await api.trends(machineId, c.metric).catch(() => null);
    const pts = (trend && trend.points) || [];
    const judged = pts.find((p) => p.measurement_id === c.measurement_id);
    if (!judged || !judged.direction) continue;
    const t = Date.parse(judged.measured_at);
    const partner = pts
      .filter((p) => p.test_id === judged.test_id && p.direction && p.direction !== judged.direction && Math.abs(Date.parse(p.measured_at) - t) <= 3_600_000)
      .sort((a, b) => Math.abs(Date.parse(a.measured_at) - t) - Math.abs(Date.parse(b.measured_at) - t))[0];
    if (!partner) continue;
    const unit = unitOfMetric(metrics, 'dbb', c.metric);
    const minutes = Math.round(Math.abs(t - Date.parse(partner.measured_at)) / 60000);
    const when = minutes === 0 ? 'at the same time as' : `${minutes} min ${t > Date.parse(partner.measured_at) ? 'after' : 'before'}`;
    notes.set(
      c.rule,
      `Judged: the ${formatDirection(judged.direction)} test #${judged.measurement_id} (${fmt(judged.value)} ${unit}), the machine's newest DBB test, measured ${when} its ${formatDirection(partner.direction)} partner #${partner.measurement_id} (${fmt(partner.value)} ${unit}). A rule reads the newest result of its kind; ${judged.value >= partner.value ? 'here it is also the worse of the two.' : `the partner is worse: a rule on circular_hysteresis_um or a check of the ${formatDirection(partner.direction)} test covers it.`}`,
    );
  }
  return notes;
}

async function loadAudit(machineId) {
  const [audit, audits, metrics] = await Promise.all([machineAuditOrNull(machineId), orNull(api.audits(machineId, 50)), auditMetricList()]);
  const verdicts = (audits && audits.audits) || [];
  return { audit, verdicts, latest: verdicts[0] || null, metrics };
}

// ---------------------------------------------------------------- the audit view

let viewSeq = 0;

export async function showAudit(machineId) {
  const seq = ++viewSeq;
  const view = $('#audit-view');
  view.dataset.machineId = machineId;
  $('#audit-heading').textContent = `Accuracy audit — ${machineId}`;
  $('#machine-audit-summary').replaceChildren(); // the view shows it in full
  $('#audit-report-pdf').hidden = true; // offered once the machine's audit is known to exist
  hideCertificate('audit');
  const body = $('#audit-body');
  body.setAttribute('aria-busy', 'true');
  try {
    const data = await loadAudit(machineId);
    const pairNotes = await pairNotesOf(machineId, data.latest, data.metrics);
    if (seq !== viewSeq) return;
    view.dataset.auditLevel = data.latest ? String(data.latest.level) : 'none';
    $('#audit-run').hidden = !data.audit;
    $('#audit-report-pdf').hidden = !data.audit; // no audit: its report is a 404
    if (data.audit) showAuditCertificate(machineId);
    body.replaceChildren(
      h(
        'p',
        { class: 'audit-verdict' },
        levelBadge(data.latest),
        data.latest ? ` — audit #${data.latest.id} of ${formatTimestamp(data.latest.created_at)} (${data.latest.trigger === 'schedule' ? 'scheduled' : 'on request'})` : '',
        data.audit ? ` · schedule: ${data.audit.schedule || 'on request only'}` : '',
        data.audit ? ` · stale after ${plural(Number.isInteger(data.audit.max_age_days) ? data.audit.max_age_days : DEFAULT_MAX_AGE_DAYS, 'day')}${data.audit.stale === 'warn' ? ' (level 2)' : ''}` : '',
        data.audit && data.audit.next_run_at ? `, next ${formatTimestamp(data.audit.next_run_at)}` : '',
        ' · ',
        h('a', { href: trendsHash(machineId), 'data-testid': 'audit-trends-link' }, 'trends'),
      ),
      h('h3', {}, 'Rules'),
      rulesTable(data.audit, data.latest, data.metrics, pairNotes),
      h('h3', {}, 'Findings of the newest audit'),
      findingsList(data.latest),
      staleList(data.latest, data.audit),
      data.latest && (data.latest.checked || []).some((c) => c.set_up !== undefined) ? h('h3', {}, 'Set-ups judged by the newest audit') : '',
      data.latest && (data.latest.checked || []).some((c) => c.set_up !== undefined) ? checkedTable(data.latest, data.audit, data.metrics) : '',
      h('h3', {}, 'History'),
      historyTable(data.verdicts),
    );
    ruleEditor(data.audit, data.metrics);
  } catch (err) {
    if (!handleAuth(err)) body.replaceChildren(errorBox(err));
  } finally {
    body.removeAttribute('aria-busy');
  }
}

// ---------------------------------------------------------------- beside the measurement list

let summarySeq = 0;

export async function showAuditSummary(machineId) {
  const seq = ++summarySeq;
  const box = $('#machine-audit-summary');
  $('#machine-audit-link').href = auditHash(machineId);
  $('#machine-audit-link').hidden = false;
  try {
    const data = await loadAudit(machineId);
    if (seq !== summarySeq || $('#audit-view').hidden === false) return;
    box.replaceChildren(
      h('p', { class: 'audit-verdict' }, 'Audit: ', levelBadge(data.latest, 'machine-audit-level'), data.latest ? ` (${formatTimestamp(data.latest.created_at)})` : ''),
      data.audit ? rulesTable(data.audit, data.latest, data.metrics, new Map(), true) : h('p', { class: 'note' }, 'No audit rules yet.'),
      data.latest && (data.latest.findings || []).length ? findingsList(data.latest) : '',
    );
  } catch (err) {
    if (!handleAuth(err)) box.replaceChildren(errorBox(err));
  }
}

export function resetAuditSummary() {
  ++summarySeq;
  $('#machine-audit-summary').replaceChildren();
  $('#machine-audit-link').hidden = true;
}

// ---------------------------------------------------------------- saving and running

async function onSave(event) {
  event.preventDefault();
  const machineId = $('#audit-view').dataset.machineId;
  const status = $('#audit-form-status');
  const checked = checkRules(await auditMetricList());
  if (checked.error) {
    setMessage(status, 'error', ...problemContent({ title: 'Rules not saved', detail: checked.error.detail, field: checked.error.field }));
    return;
  }
  $('#audit-save').disabled = true;
  try {
    await api.putAudit(machineId, checked.body);
    noteRuleCount(machineId, checked.body.rules.length);
    await showAudit(machineId); // redraws the form too (which clears its status)
    setMessage(status, 'success', `Saved ${checked.body.rules.length} rule${checked.body.rules.length === 1 ? '' : 's'} for ${machineId}.`);
  } catch (err) {
    if (!handleAuth(err)) setMessage(status, 'error', ...(refusalContent(err, 'set audit rules') || problemContent(asProblem(err, 'Rules not saved'))));
  } finally {
    $('#audit-save').disabled = false;
  }
}

async function onRun() {
  const machineId = $('#audit-view').dataset.machineId;
  const status = $('#audit-status');
  $('#audit-run').disabled = true;
  try {
    const verdict = await api.runAudit(machineId);
    await showAudit(machineId);
    setMessage(status, verdict.level > 1 ? 'warning' : 'success', `Audit #${verdict.id}: ${auditWords(verdict.level)}.`);
  } catch (err) {
    if (!handleAuth(err)) setMessage(status, 'error', ...(refusalContent(err, 'run audits') || problemContent(asProblem(err, 'Audit not run'))));
  } finally {
    $('#audit-run').disabled = false;
  }
}

export function initAudit() {
  $('#audit-form').addEventListener('submit', onSave);
  $('#audit-run').addEventListener('click', onRun);
}
