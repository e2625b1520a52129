// Hexapod calibration: the panel that starts a study from the machine's DBB tests (shown for
// hexapod machines only), the job view (#/jobs/{id}) with the server's verdict — a calibration
// that is ill-conditioned, not converged or under-determined shows the reasons and no "after"
// figures — and the job history of the machine in the sidebar.

import { api, ApiError } from './api.js';
import { handleAuth } from './auth.js';
import { JOB_STATUS, JOB_VERDICT } from './contract.js';
import { $, asProblem, downloadText, errorBox, h, keepFocus, problemContent, setMessage } from './dom.js';
import { formatDirection, formatMode, formatNumber, formatTimestamp, formatUncertainty, plural } from './format.js';
import { cancelledContent, jobCancelControl } from './job_cancel.js';
import { pollJob, selectMachineOfJob } from './job_poll.js';
import { hideCertificate, showJobCertificate } from './reports.js';
import { jobHash, navigate } from './router.js';
import { state } from './state.js';

// ---------------------------------------------------------------- the panel

export function resetCalibration() {
  state.calibChecked = new Set();
  $('#calibration').hidden = true;
  $('#calib-measurements').replaceChildren();
  setMessage($('#calib-status'), null);
}

// The panel lists the DBB tests of the selected machine; only hexapod machines have it.
export function renderCalibrationChoices() {
  const dbb = state.dbb;
  $('#calibration').hidden = !state.hexapod || dbb.length === 0;
  const known = new Set(dbb.map((m) => m.id));
  state.calibChecked = new Set([...state.calibChecked].filter((id) => known.has(id)));
  $('#calib-measurements').replaceChildren(
    ...dbb.map((m) => {
      const id = `calib-m-${m.id}`;
      return h(
        'label',
        { class: 'calib-choice', for: id },
        h('input', {
          type: 'checkbox',
          id,
          value: m.id,
          'data-testid': 'calib-choice',
          'data-id': m.id,
          checked: state.calibChecked.has(m.id),
          onchange: (e) => {
            if (e.target.checked) state.calibChecked.add(m.id);
            else state.calibChecked.delete(m.id);
          },
        }),
        h('span', {}, `${m.test_id || m.filename || `#${m.id}`}`),
        m.direction ? h('span', { class: `badge dir-${m.direction}` }, formatDirection(m.direction)) : '',
        h('span', { class: 'item-meta' }, `#${m.id}`),
      );
    }),
  );
}

function setAllCalibChecks(on) {
  state.calibChecked = on ? new Set(state.dbb.map((m) => m.id)) : new Set();
  for (const box of document.querySelectorAll('#calib-measurements input[type="checkbox"]')) box.checked = on;
}

function calibError(title, detail) {
  setMessage($('#calib-status'), 'error', h('strong', { class: 'problem-title' }, title), h('span', { class: 'problem-detail' }, detail));
}

async function onCalibrate(event) {
  event.preventDefault();
  const ids = state.dbb.map((m) => m.id).filter((id) => state.calibChecked.has(id));
  const fileInput = $('#calib-machine-file');
  const file = fileInput.files && fileInput.files[0];
  if (!ids.length) {
    calibError('No measurement chosen', 'Tick the DBB measurements to use.');
    return;
  }
  if (!file) {
    calibError('No machine definition', 'Choose the machine definition JSON file (kinemetric-machine/1).');
    fileInput.focus();
    return;
  }
  let machine;
  try {
    machine = JSON.parse(await file.text());
  } catch (err) {
    calibError('Machine definition is not valid JSON', `${file.name}: ${err.message}`);
    return;
  }
  if (!machine || typeof machine !== 'object' || Array.isArray(machine)) {
    calibError('Machine definition is not a JSON object', file.name);
    return;
  }
  const body = { machine, measurement_ids: ids };
  const method = $('#calib-method').value;
  if (method) body.method = method;
  const button = $('#calib-run');
  button.disabled = true;
  setMessage($('#calib-status'), 'info', `Submitting a calibration with ${ids.length} DBB test${ids.length === 1 ? '' : 's'}…`);
  try {
    const { job_id: jobId } = await api.calibrate(body);
    $('#calib-status').dataset.jobId = jobId;
    setMessage($('#calib-status'), 'info', h('a', { href: jobHash(jobId) }, `Job #${jobId} submitted`), ' — its page follows it.');
    navigate(jobHash(jobId));
    loadJobHistory();
  } catch (err) {
    if (!handleAuth(err)) setMessage($('#calib-status'), 'error', ...problemContent(asProblem(err, 'Calibration failed')));
  } finally {
    button.disabled = false;
  }
}

// ---------------------------------------------------------------- job history (sidebar)

function jobLink(j) {
  return j.kind === 'discovery' ? `#/discoveries/${j.id}` : jobHash(j.id);
}

const KIND_WORDS = { hexapod_calibration: 'Calibration', discovery: 'Discovery' };

export async function loadJobHistory() {
  const machineId = state.machineId;
  const panel = $('#jobs-panel');
  panel.hidden = !machineId;
  if (!machineId) return;
  const list = $('#jobs');
  try {
    const data = await api.machineJobs(machineId, 50);
    if (machineId !== state.machineId) return;
    const jobs = data.items || [];
    if (!jobs.length) {
      list.replaceChildren(h('li', { class: 'empty' }, 'No calibration or discovery of this machine yet.'));
      return;
    }
    keepFocus(list, () =>
      list.replaceChildren(
        ...jobs.map((j) =>
          h(
            'li',
            {},
            h(
              'a',
              {
                class: 'item',
                href: jobLink(j),
                'data-testid': 'job-item',
                'data-job-id': j.id,
                'data-kind': j.kind,
                'data-status': j.status,
                'data-verdict': j.verdict || '',
                'data-focus-key': `job:${j.id}`,
              },
              h(
                'span',
                { class: 'item-title' },
                `${KIND_WORDS[j.kind] || String(j.kind).replace(/_/g, ' ')} #${j.id}`,
                h('span', { class: `badge job-${j.verdict || j.status}` }, j.verdict || j.status),
              ),
              h('span', { class: 'item-meta' }, `${plural((j.request?.measurement_ids || []).length, 'test')} · ${formatTimestamp(j.created_at)}`),
            ),
          ),
        ),
      ),
    );
  } catch (err) {
    if (!handleAuth(err)) list.replaceChildren(h('li', { class: 'empty' }, errorBox(err)));
  }
}

// ---------------------------------------------------------------- the job view

let showCancel = () => {}; // the view's Cancel button (initCalibration)

export async function showJob(jobId) {
  const seq = ++state.jobSeq;
  showCancel(null);
  hideCertificate('job'); // asked once the job has ended (its report changes while it runs)
  const view = $('#job-view');
  view.dataset.jobId = String(jobId);
  view.dataset.jobVerdict = '';
  $('#job-heading').textContent = `Calibration — job #${jobId}`;
  $('#job-result').replaceChildren();
  const status = $('#job-status');
  setMessage(status, 'info', `Loading job #${jobId}…`);
  delete status.dataset.status;
  let machineShown = false;
  await pollJob(jobId, {
    current: () => seq === state.jobSeq,
    show: (job) => {
      if (job.kind === 'discovery') {
        window.history.replaceState(null, '', `#/discoveries/${jobId}`);
        window.dispatchEvent(new HashChangeEvent('hashchange'));
        return false;
      }
      if (!machineShown) {
        machineShown = true;
        selectMachineOfJob(job);
      }
      status.dataset.status = job.status;
      $('#job-sub').textContent = requestSummary(job);
      showCancel(job);
      return true;
    },
    ended: (job) => {
      if (job.status === JOB_STATUS.cancelled) {
        setMessage(status, 'info', ...cancelledContent(job));
      } else {
        view.dataset.jobVerdict = job.verdict || '';
        setMessage(status, null);
        renderJob(job);
      }
      showJobCertificate('job', job);
      loadJobHistory();
    },
    waiting: (job) => setMessage(status, 'info', ...jobStatusContent(job)),
    failedToLoad: (err) => {
      if (!handleAuth(err)) {
        const title = err instanceof ApiError && err.status === 404 ? `Job #${jobId} not found` : 'Could not load the job';
        setMessage(status, 'error', ...problemContent(asProblem(err, title)));
      }
    },
  });
}

function requestSummary(job) {
  const req = job.request || {};
  const n = (req.measurement_ids || []).length;
  return `${n} DBB test${n === 1 ? '' : 's'} · machine ${req.machine_id || '?'}${req.method ? ` · ${req.method}` : ''} · submitted ${formatTimestamp(job.created_at)}`;
}

function jobStatusContent(job) {
  const pct = Math.round(100 * (Number(job.progress) || 0));
  return [
    h('strong', { class: 'problem-title' }, `Job #${job.id}: ${job.status}`),
    h('span', { class: 'job-stage', 'data-testid': 'job-stage' }, `${job.stage || ''}`.replace(/_/g, ' ')),
    h('progress', { max: 100, value: pct, 'data-testid': 'job-progress' }, `${pct} %`),
  ];
}

const VERDICT_WORDS = {
  ok: ['Calibration finished', 'The parameters are determined by the tests; the predicted figures after the correction follow.'],
  warning: ['Calibration not trustworthy', 'The job finished, but its parameters are not determined by these tests: no predicted “after” figures and no corrected machine file.'],
  failed: ['Calibration failed', 'No parameters and no figures.'],
};

function verdictBanner(job) {
  const verdict = job.verdict || (job.status === JOB_STATUS.failed ? JOB_VERDICT.failed : JOB_VERDICT.warning);
  const [title, say] = VERDICT_WORDS[verdict] || VERDICT_WORDS.warning;
  const reasons = job.verdict_reasons && job.verdict_reasons.length ? job.verdict_reasons : job.error ? [job.error] : [];
  return h(
    'div',
    { class: `verdict verdict-${verdict}`, role: verdict === JOB_VERDICT.ok ? 'status' : 'alert', 'data-testid': 'job-verdict', 'data-verdict': verdict },
    h('strong', { class: 'verdict-title' }, title),
    h('span', { class: 'verdict-detail' }, say),
    reasons.length ? h('ul', { class: 'verdict-reasons' }, ...reasons.map((r) => h('li', { 'data-testid': 'verdict-reason' }, r))) : '',
  );
}

// "strut_offset_um[2]" → "Strut 3 length offset"; "base_joint_offset_um[1][2]" → "Base joint 2 Z".
export function parameterName(name) {
  let m = String(name).match(/^strut_offset_um\[(\d+)\]$/);
  if (m) return `Strut ${Number(m[1]) + 1} length offset`;
  m = String(name).match(/^base_joint_offset_um\[(\d+)\]\[(\d+)\]$/);
  if (m) return `Base joint ${Number(m[1]) + 1} ${'XYZ'[Number(m[2])] || m[2]}`;
  return String(name).replace(/_um$/, '').replace(/_/g, ' ');
}

function renderJob(job) {
  const box = $('#job-result');
  if (job.status === JOB_STATUS.failed) {
    box.replaceChildren(verdictBanner(job));
    return;
  }
  const r = job.result || {};
  const trusted = job.verdict === JOB_VERDICT.ok;
  box.replaceChildren(verdictBanner(job), summaryList(r), testsTable(r, trusted), paramsTable(r), actions(job, r, trusted));
}

function summaryList(r) {
  const f3 = (v) => formatNumber(v, '_um');
  const fixed = Array.isArray(r.fixed_parameters) ? r.fixed_parameters : [];
  const items = [
    ['method', 'Method', formatMode(r.method)],
    ['residual_rms_um', 'Residual RMS', `${f3(r.residual_rms_um)} µm`],
    ['condition_number', 'Condition number', formatNumber(r.condition_number)],
    ['converged', 'Converged', r.converged === undefined ? '—' : r.converged ? `yes (${r.iterations ?? '?'} iterations)` : 'no'],
    ['fixed_parameters', 'Fixed parameters', fixed.length ? fixed.map(parameterName).join(', ') : 'none'],
  ];
  // Each term with its value in one block, so a wrapped line keeps all its letters.
  return h('dl', { class: 'calib-summary', 'data-testid': 'calib-summary' }, ...items.map(([key, label, value]) => h('div', {}, h('dt', {}, label), h('dd', { 'data-key': key }, value))));
}

function testsTable(r, trusted) {
  const f3 = (v) => formatNumber(v, '_um');
  const tests = Array.isArray(r.tests) ? r.tests : [];
  const pairs = [
    ['centre_deviation_before_um', 'Centre dev. before (µm)', 'centre_deviation_predicted_after_um'],
    ['average_radial_error_before_um', 'Avg radial err. before (µm)', 'average_radial_error_predicted_after_um'],
    ['circularity_before_um', 'Circularity before (µm)', 'predicted_circularity_after_um'],
  ];
  const head = [h('th', { scope: 'col' }, 'Test'), h('th', { scope: 'col' }, 'Direction')];
  for (const [, label] of pairs) {
    head.push(h('th', { scope: 'col', class: 'num' }, label));
    if (trusted) head.push(h('th', { scope: 'col', class: 'num' }, 'predicted after (µm)'));
  }
  const table = h(
    'table',
    { class: 'figures small calib-tests', 'data-testid': 'calib-tests-table', 'data-after': trusted ? 'shown' : 'withheld' },
    h(
      'caption',
      {},
      trusted ? 'Before and predicted after the correction ([PM-600 report] table 2.2)' : 'The tests before calibration (no prediction: see the verdict)',
      tests.some((t) => t.deviation_units === 'bar') ? h('span', { class: 'units-note', 'data-testid': 'calib-units' }, ' — in bar units ([PM-600 report] eq. 4.8; a cone test\u2019s tool-path figure is bar length / radius times it)') : null,
    ),
    h('thead', {}, h('tr', {}, ...head)),
    h(
      'tbody',
      {},
      ...tests.map((t, i) => {
        const cells = [h('td', { 'data-key': 'test_id' }, t.test_id ?? '—'), h('td', { 'data-key': 'direction' }, formatDirection(t.direction))];
        for (const [before, , after] of pairs) {
          cells.push(h('td', { class: 'num', 'data-key': before }, f3(t[before])));
          if (trusted) cells.push(h('td', { class: 'num', 'data-key': after }, f3(t[after])));
        }
        return h('tr', { 'data-index': i }, ...cells);
      }),
    ),
  );
  return h('div', { class: 'table-scroll' }, table);
}

function paramsTable(r) {
  const f3 = (v) => formatNumber(v, '_um');
  const p = r.parameters || {};
  const u = r.parameter_uncertainty_um || {};
  const fixed = new Set(Array.isArray(r.fixed_parameters) ? r.fixed_parameters : []);
  const cell = (name, v, s) =>
    h(
      'td',
      { class: `num${fixed.has(name) ? ' fixed' : ''}`, 'data-param': name, title: fixed.has(name) ? `${parameterName(name)}: fixed (not identifiable from these tests)` : parameterName(name) },
      fixed.has(name) ? `${f3(v)} (fixed)` : `${f3(v)} ± ${formatUncertainty(s)}`,
    );
  const table = h(
    'table',
    { class: 'figures small calib-params', 'data-testid': 'calib-params-table' },
    h('caption', {}, 'Identified parameters (µm, ± standard uncertainty)'),
    h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Strut'), h('th', { scope: 'col', class: 'num' }, 'Length offset'), h('th', { scope: 'col', class: 'num' }, 'Base joint X'), h('th', { scope: 'col', class: 'num' }, 'Base joint Y'), h('th', { scope: 'col', class: 'num' }, 'Base joint Z'))),
    h(
      'tbody',
      {},
      ...[0, 1, 2, 3, 4, 5].map((j) =>
        h(
          'tr',
          { 'data-strut': j },
          h('th', { scope: 'row' }, String(j + 1)),
          cell(`strut_offset_um[${j}]`, p.strut_offset_um?.[j], u.strut_offset_um?.[j]),
          ...[0, 1, 2].map((c) => cell(`base_joint_offset_um[${j}][${c}]`, p.base_joint_offset_um?.[j]?.[c], u.base_joint_offset_um?.[j]?.[c])),
        ),
      ),
    ),
  );
  return h('div', { class: 'table-scroll' }, table);
}

// The corrected machine file (as `hexapod calibrate --write-machine` writes it) and saving it as
// the next model version: only for a calibration the verdict trusts.
function actions(job, r, trusted) {
  const box = h('div', { class: 'disc-actions', 'data-testid': 'job-actions' });
  const status = h('div', { class: 'message', 'data-testid': 'job-save-status', 'aria-live': 'polite', hidden: true });
  if (trusted && r.calibrated_machine) {
    const name = `${r.calibrated_machine.machine_id || 'machine'}-calibrated-job-${job.id}.json`;
    box.append(
      h('button', { type: 'button', 'data-testid': 'job-download-machine', onclick: () => downloadText(`${JSON.stringify(r.calibrated_machine, null, 2)}\n`, name, 'application/json') }, 'Download corrected machine file'),
    );
    const save = h(
      'button',
      {
        type: 'button',
        class: 'secondary',
        'data-testid': 'job-save-machine',
        'data-min-role': 'engineer',
        onclick: async () => {
          save.disabled = true;
          try {
            const out = await api.saveJobMachine(job.id);
            setMessage(status, 'success', out.created ? `Saved as ${out.machine_id} version ${out.version}.` : `Already stored as ${out.machine_id} version ${out.version}.`);
          } catch (err) {
            if (!handleAuth(err)) setMessage(status, 'error', ...problemContent(asProblem(err, 'Not saved')));
          } finally {
            save.disabled = false;
          }
        },
      },
      'Save as new machine model version',
    );
    box.append(save);
  } else {
    box.append(h('span', { class: 'note' }, 'No corrected machine file: the verdict does not trust these parameters.'));
  }
  box.append(h('button', { type: 'button', class: 'secondary', 'data-testid': 'job-download-json', onclick: () => downloadText(`${JSON.stringify(job, null, 2)}\n`, `kinemetric-job-${job.id}.json`, 'application/json') }, 'Download job (JSON)'));
  return h('div', {}, box, status);
}

export function initCalibration() {
  $('#calib-form').addEventListener('submit', onCalibrate);
  $('#calib-all').addEventListener('click', () => setAllCalibChecks(true));
  $('#calib-none').addEventListener('click', () => setAllCalibChecks(false));
  $('#job-print').addEventListener('click', () => window.print());
  showCancel = jobCancelControl($('#job-cancel'), $('#job-cancel-status'));
}
