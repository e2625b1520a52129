// Model-gap discovery page ([PM-600 report] ch. 4–5): start a discovery study of a machine's DBB
// tests against a stored machine model (or none: the serial study), follow the background job
// (step and candidate being tried) and show its result — verdict, the steps with their evidence,
// the gap shrinking step by step down to the noise floor, the gap of every test at every step,
// the final model with its uncertainties, the compensation preview ([PM-600 report] table 4.5),
// saving the updated machine as a new model version, and the result JSON.
//
// Addresses: #/discoveries?machine=ID (the start form) and #/discoveries/JOB_ID (one job), so a
// reload keeps the page. The result is the JSON of `kinemetric discover --json`
// (report/discovery_json.cpp); the job is served by GET /api/v1/jobs/{id}.

import { api, ApiError } from './api.js';
import { axesGrid, el, r2, ticks } from './charts.js';
import { $, asProblem, errorBox, h, problemContent, setMessage } from './dom.js';
import { displayUnit, effectWords, formatDirection, formatNumber, formatTimestamp } from './format.js';


const JOB_POLL_MS = 500;
// The engine's default maximum number of steps (analysis/discovery/engine.h, EngineOptions): the
// job reports its progress as step / (max_steps + 1). Used only when the stage text does not
// name the step.
const ENGINE_MAX_STEPS = 8;
const JOB_LIST_LIMIT = 200;

const ctx = {
  getMachineId: () => null,
  getMachines: () => [],
  getMeasurements: () => [],
  handleAuth: () => false,
  selectMachine: async () => {},
  reloadMachines: async () => {},
};

const state = {
  route: { view: 'detail' },
  seq: 0, // a new route stops the polling / rendering of the previous one
  checked: new Map(), // machine id → Set of ticked DBB measurement ids
  formMachine: null,
  models: [], // machines with a stored model: [{machine_id, model_versions}]
  jobs: [], // discovery jobs of the selected machine (list, without results)
  jobsMachine: null, // the machine state.jobs belongs to
  jobsSeq: 0,
  jsonUrl: null, // object URL of the result JSON offered for download
};

// ---------------------------------------------------------------- words and numbers

const minus = (s) => String(s).replace(/-/g, '−');

// Parameters of the hexapod effects (analysis/hexapod/effects/*.cpp) in words, with the unit
// they are shown in and the factor from the stored unit to it.
const PARAMETERS = {
  K_stiff2_mm_per_N: { label: 'Compliance of joints and platform (per strut)', unit: 'µm/kN', factor: 1e6 },
  torque_Nm: { label: 'Base-joint friction torque', unit: 'N·m', factor: 1 },
  ramp_mm: { label: 'Friction build-up after a reversal (ramp length)', unit: 'mm', factor: 1 },
  torque_per_N_m: { label: 'Friction torque per unit strut force', unit: 'N·m/kN', factor: 1e3 },
  lag_coefficient_ms2: { label: 'Servo lag coefficient (1 − K_f²)/K_pp²', unit: 'ms²', factor: 1 },
  rate_um_per_h: { label: 'Thermal drift rate', unit: 'µm/h', factor: 1 },
  um_per_K: { label: 'Thermal growth per kelvin', unit: 'µm/K', factor: 1 },
};

// Units as the analysis writes them → [display unit, factor] (fallback for unknown parameters).
const SUFFIX_UNITS = [
  ['_um_per_m', 'µm/m', 1],
  ['_um_per_h', 'µm/h', 1],
  ['_mm_per_N', 'µm/kN', 1e6],
  ['_um', 'µm', 1],
  ['_mm', 'mm', 1],
  ['_Nm', 'N·m', 1],
  ['_deg', '°', 1],
  ['_ms2', 'ms²', 1],
  ['_ms', 'ms', 1],
  ['_ppm', 'ppm', 1],
  ['_pct', '%', 1],
];

export function parameterWords(name) {
  const n = String(name || '');
  if (PARAMETERS[n]) return PARAMETERS[n];
  let m = n.match(/^error_um\[([^\]]+)\]$/);
  if (m) return { label: `Tool length error (tool of ${m[1]} mm)`, unit: 'µm', factor: 1 };
  for (const [suffix, unit, factor] of SUFFIX_UNITS) {
    if (n.endsWith(suffix)) {
      const words = n.slice(0, -suffix.length).replace(/_/g, ' ');
      return { label: words.charAt(0).toUpperCase() + words.slice(1), unit, factor };
    }
  }
  m = n.replace(/_/g, ' ');
  return { label: m.charAt(0).toUpperCase() + m.slice(1), unit: '', factor: 1 };
}

// "ramp_mm = 2" (an effect variant) → "ramp length 2 mm".
export function variantWords(variant) {
  const v = String(variant || '').trim();
  if (!v) return '';
  const m = v.match(/^([A-Za-z_][\w[\].]*)\s*=\s*(.+)$/);
  if (!m) return v.replace(/_/g, ' ');
  if (m[1] === 'ramp_mm') return `ramp length ${m[2]} mm`;
  const p = parameterWords(m[1]);
  const value = Number(m[2]);
  const shown = Number.isFinite(value) ? String(Number((value * p.factor).toPrecision(6))) : m[2];
  return `${p.label.charAt(0).toLowerCase()}${p.label.slice(1)} ${shown}${p.unit ? ` ${p.unit}` : ''}`;
}

// Effect words inside a sentence: "joint friction", but "backlash in X".
function effectInText(effect, variant) {
  const w = effectLabel(effect, variant);
  return `${w.charAt(0).toLowerCase()}${w.slice(1)}`;
}

function effectLabel(effect, variant) {
  const w = variantWords(variant);
  return w ? `${effectWords(effect)} (${w})` : effectWords(effect);
}

function um(v) {
  return formatNumber(v, '_um');
}

function fixedText(v, decimals) {
  let s = v.toFixed(decimals);
  if (/^-0\.?0*$/.test(s)) s = s.slice(1);
  return minus(s);
}

// Value ± standard uncertainty, the uncertainty to two significant digits and the value to the
// same decimal place (GUM 7.2.6); without an uncertainty, four significant digits.
export function valuePm(value, sigma) {
  if (typeof value !== 'number' || !Number.isFinite(value)) return '—';
  if (typeof sigma === 'number' && Number.isFinite(sigma) && sigma > 0) {
    const decimals = Math.min(8, Math.max(0, 1 - Math.floor(Math.log10(sigma))));
    return `${fixedText(value, decimals)} ± ${fixedText(sigma, decimals)}`;
  }
  return plain(value);
}

function plain(value) {
  if (typeof value !== 'number' || !Number.isFinite(value)) return '—';
  if (value === 0) return '0';
  const abs = Math.abs(value);
  if (abs >= 1e6 || abs < 1e-4) return minus(value.toExponential(3));
  return minus(String(Number(value.toPrecision(4))));
}

// p-value from its log10 (the F-test p of a strong effect underflows to 0): "1.4 × 10⁻¹¹²⁹³".
function pValueNodes(p, log10p) {
  let lg = typeof log10p === 'number' && Number.isFinite(log10p) ? log10p : null;
  if (lg === null && typeof p === 'number' && p > 0) lg = Math.log10(p);
  if (lg === null) return typeof p === 'number' ? [plain(p)] : ['—'];
  if (lg >= -3) return [fixedText(10 ** lg, 4)];
  let e = Math.floor(lg);
  let m = 10 ** (lg - e);
  if (m >= 9.95) {
    m = 1;
    e += 1;
  }
  return [`${m.toFixed(1)} × 10`, h('sup', {}, minus(String(e)))];
}

function pct(v, decimals = 1) {
  return `${fixedText(v, decimals)} %`;
}

// ---------------------------------------------------------------- routing

export function parseRoute(hash = window.location.hash) {
  const s = String(hash || '').replace(/^#/, '');
  let m = s.match(/^\/discoveries\/(\d+)\/?$/);
  if (m) return { view: 'discovery', jobId: Number(m[1]) };
  m = s.match(/^\/discoveries\/?(?:new)?\/?(?:\?(.*))?$/);
  if (m) return { view: 'discovery-new', machine: new URLSearchParams(m[1] || '').get('machine') };
  return { view: 'detail' };
}

export function isDiscoveryRoute() {
  return parseRoute().view !== 'detail';
}

function newFormHash(machineId) {
  return machineId ? `#/discoveries?machine=${encodeURIComponent(machineId)}` : '#/discoveries';
}

function jobHash(jobId) {
  return `#/discoveries/${jobId}`;
}

// Back to the measurement view (the address without a discovery route).
export function leaveDiscovery() {
  if (!isDiscoveryRoute()) return;
  window.history.pushState(null, '', window.location.pathname + window.location.search);
  applyRoute();
}

function showView(discovery) {
  $('#detail').hidden = discovery;
  $('#discovery').hidden = !discovery;
}

// Narrow screens show the page in one column under the top bar: scroll to its start.
function bringIntoView() {
  if (window.matchMedia && window.matchMedia('(max-width: 1000px)').matches) $('#discovery').scrollIntoView({ block: 'start' });
}

// Shows what the address names. Called at start, on hashchange and after leaveDiscovery().
export function applyRoute() {
  const route = parseRoute();
  state.route = route;
  const seq = ++state.seq;
  if (route.view === 'detail') {
    showView(false);
    renderDiscoveryList();
    return;
  }
  showView(true);
  bringIntoView();
  $('#discovery-new').hidden = route.view !== 'discovery-new';
  $('#discovery-job').hidden = route.view !== 'discovery';
  renderDiscoveryList();
  if (route.view === 'discovery-new') {
    $('#discovery-heading').textContent = 'New model-gap discovery';
    if (route.machine && route.machine !== ctx.getMachineId()) {
      ctx.selectMachine(route.machine); // renderForm runs again when its measurements are in
    }
    renderForm();
  } else {
    $('#discovery-heading').textContent = `Model-gap discovery — job #${route.jobId}`;
    showJob(route.jobId, seq);
  }
}

// The selected machine or its measurements changed (app.js, after they are loaded).
export function discoveryMachineChanged() {
  const route = parseRoute();
  if (route.view === 'discovery-new') {
    const id = ctx.getMachineId();
    if (id && route.machine !== id) window.history.replaceState(null, '', newFormHash(id));
    renderForm();
  }
  refreshDiscoveryList();
}

// ---------------------------------------------------------------- past discoveries (sidebar)

function jobBelongsTo(job, machineId, measurementIds) {
  const req = job.request || {};
  const ids = Array.isArray(req.measurement_ids) ? req.measurement_ids : [];
  if (ids.some((id) => measurementIds.has(id))) return true;
  return req.machine_id === machineId;
}

export async function refreshDiscoveryList() {
  const machineId = ctx.getMachineId();
  const panel = $('#discoveries-panel');
  panel.hidden = !machineId;
  $('#discovery-new-link').setAttribute('href', newFormHash(machineId));
  if (!machineId) return;
  const seq = ++state.jobsSeq;
  const list = $('#discoveries');
  if (state.jobsMachine !== machineId) {
    // Another machine: its list, not the previous one's, once it is in.
    state.jobs = [];
    list.replaceChildren(h('li', { class: 'empty' }, 'Loading…'));
  }
  list.setAttribute('aria-busy', 'true');
  try {
    const data = await api.jobs(JOB_LIST_LIMIT);
    if (seq !== state.jobsSeq || machineId !== ctx.getMachineId()) return;
    const ids = new Set(ctx.getMeasurements().map((m) => m.id));
    state.jobs = (data.items || []).filter((j) => j.kind === 'discovery' && jobBelongsTo(j, machineId, ids));
    state.jobsMachine = machineId;
    renderDiscoveryList();
  } catch (err) {
    if (seq !== state.jobsSeq) return;
    if (!ctx.handleAuth(err)) list.replaceChildren(h('li', { class: 'empty' }, errorBox(err)));
  } finally {
    if (seq === state.jobsSeq) list.removeAttribute('aria-busy');
  }
}

function jobModelText(req) {
  if (!req || !req.machine_id) return 'serial study (no model)';
  return `model ${req.machine_id}${req.machine_version ? ` v${req.machine_version}` : ''}`;
}

function renderDiscoveryList() {
  const list = $('#discoveries');
  const machineId = ctx.getMachineId();
  $('#discoveries-sub').textContent = machineId ? `Discoveries of the DBB tests of ${machineId}` : '';
  if (!state.jobs.length) {
    const loading = machineId && state.jobsMachine !== machineId;
    list.replaceChildren(h('li', { class: 'empty' }, loading ? 'Loading…' : 'No discovery of this machine yet.'));
    return;
  }
  const current = state.route.view === 'discovery' ? state.route.jobId : null;
  list.replaceChildren(
    ...state.jobs.map((j) => {
      const n = Array.isArray(j.request?.measurement_ids) ? j.request.measurement_ids.length : 0;
      return h(
        'li',
        {},
        h(
          'a',
          {
            class: 'item',
            href: jobHash(j.id),
            'data-testid': 'discovery-item',
            'data-job-id': j.id,
            'data-status': j.status,
            'aria-current': j.id === current ? 'page' : 'false',
          },
          h('span', { class: 'item-title' }, `Job #${j.id}`, h('span', { class: `badge job-${j.status}` }, j.status)),
          h('span', { class: 'item-meta' }, [jobModelText(j.request), `${n} test${n === 1 ? '' : 's'}`, formatTimestamp(j.created_at)].filter(Boolean).join(' · ')),
        ),
      );
    }),
  );
}

// ---------------------------------------------------------------- start form

// The DBB tests of the selected machine (the list may still be the previous machine's while
// the new one loads: those are left out).
function dbbOfMachine() {
  const machineId = ctx.getMachineId();
  return ctx
    .getMeasurements()
    .filter((m) => m.kind === 'dbb' && (!m.machine_id || m.machine_id === machineId))
    .sort((a, b) => a.id - b.id);
}

// The ticked tests of a machine; every DBB test by default (the study scores candidates on
// held-out tests, so more tests make it stronger). Remembered once the machine's tests are in.
function checkedSet(machineId) {
  const known = state.checked.get(machineId);
  if (known) return known;
  const dbb = dbbOfMachine();
  const set = new Set(dbb.map((m) => m.id));
  if (dbb.length) state.checked.set(machineId, set);
  return set;
}

function renderForm() {
  const machineId = ctx.getMachineId();
  const sub = $('#discovery-sub');
  const form = $('#disc-form');
  if (!machineId) {
    sub.textContent = 'Select a machine on the left: the study uses its DBB tests.';
    form.hidden = true;
    return;
  }
  form.hidden = false;
  sub.textContent =
    `Which physical effects does the model of ${machineId} miss? The study fits the base model to the chosen DBB tests, ` +
    'then adds one effect at a time — the one that best predicts held-out tests — until the gap is at the noise floor ' +
    'or no candidate qualifies ([PM-600 report] ch. 4–5). It runs on the server.';
  const dbb = dbbOfMachine();
  const known = new Set(dbb.map((m) => m.id));
  const checked = checkedSet(machineId);
  for (const id of [...checked]) if (!known.has(id)) checked.delete(id);
  const box = $('#disc-measurements');
  box.replaceChildren(
    ...(dbb.length
      ? dbb.map((m) => {
          const id = `disc-m-${m.id}`;
          return h(
            'label',
            { class: 'calib-choice', for: id },
            h('input', {
              type: 'checkbox',
              id,
              value: m.id,
              'data-testid': 'disc-choice',
              'data-id': m.id,
              checked: checked.has(m.id),
              onchange: (e) => {
                if (e.target.checked) checked.add(m.id);
                else checked.delete(m.id);
                updateCount();
              },
            }),
            h('span', {}, `${m.test_id || m.filename || `#${m.id}`}`),
            m.direction ? h('span', { class: `badge dir-${m.direction}` }, formatDirection(m.direction)) : '',
            h('span', { class: 'item-meta' }, `#${m.id}`),
          );
        })
      : [h('p', { class: 'placeholder' }, 'This machine has no DBB tests.')]),
  );
  updateCount();
  if (state.formMachine !== machineId) {
    state.formMachine = machineId;
    setMessage($('#disc-form-status'), null);
    loadModels();
  }
}

function updateCount() {
  const machineId = ctx.getMachineId();
  const n = machineId ? checkedSet(machineId).size : 0;
  $('#disc-count').textContent = `${n} of ${dbbOfMachine().length} chosen`;
}

function setAllChecks(on) {
  const machineId = ctx.getMachineId();
  if (!machineId) return;
  const set = checkedSet(machineId);
  state.checked.set(machineId, set);
  set.clear();
  if (on) dbbOfMachine().forEach((m) => set.add(m.id));
  for (const box of document.querySelectorAll('#disc-measurements input[type="checkbox"]')) box.checked = on;
  updateCount();
}

// The model choice: machines with a stored model (machines API, model_versions > 0); the
// selected machine's own model first when it has one.
async function loadModels(prefer) {
  const machineId = ctx.getMachineId();
  const select = $('#disc-model');
  state.models = ctx.getMachines().filter((m) => (m.model_versions || 0) > 0);
  const wanted = prefer ?? (state.models.some((m) => m.machine_id === machineId) ? machineId : select.value || '');
  select.replaceChildren(
    h('option', { value: '' }, 'none — serial machine (no stored model)'),
    ...state.models.map((m) =>
      h('option', { value: m.machine_id }, `${m.machine_id} (${m.model_versions} version${m.model_versions === 1 ? '' : 's'})`),
    ),
  );
  select.value = state.models.some((m) => m.machine_id === wanted) ? wanted : '';
  await loadVersions();
}

async function loadVersions() {
  const model = $('#disc-model').value;
  const select = $('#disc-version');
  select.disabled = !model;
  if (!model) {
    select.replaceChildren(h('option', { value: '' }, '—'));
    return;
  }
  select.replaceChildren(h('option', { value: '' }, 'newest'));
  try {
    const defs = await api.machineDefinitions(model);
    if ($('#disc-model').value !== model) return;
    const versions = (defs && defs.versions) || [];
    const newest = versions.length ? versions[versions.length - 1].version : null;
    select.replaceChildren(
      h('option', { value: '' }, newest ? `newest (version ${newest})` : 'newest'),
      ...[...versions].reverse().map((v) =>
        h(
          'option',
          { value: v.version, 'data-source': v.source },
          [`version ${v.version}`, v.source, formatTimestamp(v.created_at)].filter(Boolean).join(' — '),
        ),
      ),
    );
  } catch (err) {
    if (!ctx.handleAuth(err)) setMessage($('#disc-form-status'), 'error', ...problemContent(asProblem(err, 'Could not list the model versions')));
  }
}

async function onStoreModel() {
  const input = $('#disc-machine-file');
  const file = input.files && input.files[0];
  const status = $('#disc-form-status');
  if (!file) {
    setMessage(status, 'error', h('strong', { class: 'problem-title' }, 'No file chosen'), h('span', { class: 'problem-detail' }, 'Choose a machine definition (JSON, kinemetric-machine/1).'));
    input.focus();
    return;
  }
  const button = $('#disc-store');
  button.disabled = true;
  try {
    const text = await file.text();
    const r = await api.storeMachine(text, file.name);
    setMessage(
      status,
      'success',
      r.created ? `Stored “${file.name}” as ${r.machine_id} version ${r.version}.` : `“${file.name}” is already ${r.machine_id} version ${r.version} (identical document).`,
    );
    input.value = '';
    await ctx.reloadMachines();
    await loadModels(r.machine_id);
  } catch (err) {
    if (!ctx.handleAuth(err)) setMessage(status, 'error', ...problemContent(asProblem(err, 'Not stored')));
  } finally {
    button.disabled = false;
  }
}

async function onSubmit(event) {
  event.preventDefault();
  const machineId = ctx.getMachineId();
  const status = $('#disc-form-status');
  if (!machineId) return;
  const ids = dbbOfMachine()
    .map((m) => m.id)
    .filter((id) => checkedSet(machineId).has(id));
  if (!ids.length) {
    setMessage(status, 'error', h('strong', { class: 'problem-title' }, 'No measurement chosen'), h('span', { class: 'problem-detail' }, 'Tick the DBB tests to use.'));
    return;
  }
  const body = { measurement_ids: ids };
  const model = $('#disc-model').value;
  if (model) {
    body.machine_id = model;
    const version = $('#disc-version').value;
    if (version) body.machine_version = Number(version);
  }
  const button = $('#disc-run');
  button.disabled = true;
  setMessage(status, 'info', `Submitting a discovery with ${ids.length} DBB test${ids.length === 1 ? '' : 's'}…`);
  try {
    const { job_id: jobId } = await api.discover(body);
    setMessage(status, null);
    window.location.hash = jobHash(jobId); // → applyRoute (hashchange)
    refreshDiscoveryList();
  } catch (err) {
    if (!ctx.handleAuth(err)) setMessage(status, 'error', ...problemContent(asProblem(err, 'Discovery not started')));
  } finally {
    button.disabled = false;
  }
}

// ---------------------------------------------------------------- one job

function stageWords(stage) {
  const s = String(stage || '');
  let m = s.match(/^(?:step\s+\d+\s*:\s*)?trying\s+([A-Za-z_]\w*)(?:\s*\((.*)\))?$/i);
  if (m) return `trying ${effectInText(m[1], m[2])}`;
  m = s.match(/^(?:step\s+\d+\s*:\s*)?adding\s+([A-Za-z_]\w*)$/i);
  if (m) return `adding ${effectInText(m[1])}`;
  return s.replace(/^step\s+\d+\s*:\s*/i, '').replace(/_/g, ' ');
}

// The step the job is at: named in the stage ("step 2: …"), else from the progress fraction.
function stepOf(job) {
  const m = String(job.stage || '').match(/step\s+(\d+)/i);
  if (m) return Number(m[1]);
  if (/^trying |^adding /.test(String(job.stage || ''))) {
    return Math.max(1, Math.round((Number(job.progress) || 0) * (ENGINE_MAX_STEPS + 1)));
  }
  return 0;
}

function jobStatusContent(job) {
  const pctDone = Math.round(100 * (Number(job.progress) || 0));
  const step = stepOf(job);
  return [
    h('strong', { class: 'problem-title' }, `Job #${job.id}: ${job.status}`),
    h(
      'span',
      { class: 'job-stage' },
      step ? h('span', { 'data-testid': 'disc-step', 'data-step': step }, `Step ${step}: `) : '',
      h('span', { 'data-testid': 'disc-stage' }, stageWords(job.stage) || (job.status === 'queued' ? 'waiting for the worker' : '')),
    ),
    h('progress', { max: 100, value: pctDone, 'data-testid': 'disc-progress' }, `${pctDone} %`),
  ];
}

function requestSummary(job) {
  const req = job.request || {};
  const ids = Array.isArray(req.measurement_ids) ? req.measurement_ids : [];
  const model = req.machine_id ? `stored model ${req.machine_id} version ${req.machine_version ?? 'newest'}` : 'no model (serial machine)';
  return `${ids.length} DBB test${ids.length === 1 ? '' : 's'} · ${model} · submitted ${formatTimestamp(job.created_at)}`;
}

async function showJob(jobId, seq) {
  const status = $('#disc-status');
  const result = $('#disc-result');
  result.replaceChildren();
  status.dataset.jobId = jobId;
  delete status.dataset.status;
  setMessage(status, 'info', `Loading job #${jobId}…`);
  $('#discovery-sub').textContent = '';
  let highlighted = false;
  try {
    for (;;) {
      const job = await api.job(jobId);
      if (seq !== state.seq) return;
      if (job.kind !== 'discovery') {
        setMessage(status, 'error', h('strong', { class: 'problem-title' }, `Job #${jobId} is not a discovery`), h('span', { class: 'problem-detail' }, `It is a ${String(job.kind).replace(/_/g, ' ')} job.`));
        return;
      }
      $('#discovery-sub').textContent = requestSummary(job);
      // What the view shows, for tests and links: the job and the server's verdict on it.
      $('#discovery').dataset.jobId = String(jobId);
      $('#discovery').dataset.jobVerdict = job.verdict || '';
      if (!highlighted) {
        highlighted = true;
        highlightMachineOf(job);
      }
      status.dataset.status = job.status;
      if (job.status === 'done') {
        setMessage(status, null);
        renderResult(job);
        bringIntoView();
        refreshDiscoveryList();
        return;
      }
      if (job.status === 'failed') {
        setMessage(status, null);
        renderFailed(job);
        bringIntoView();
        refreshDiscoveryList();
        return;
      }
      setMessage(status, 'info', ...jobStatusContent(job));
      await new Promise((r) => setTimeout(r, JOB_POLL_MS));
      if (seq !== state.seq) return;
    }
  } catch (err) {
    if (seq !== state.seq) return;
    if (!ctx.handleAuth(err)) {
      const title = err instanceof ApiError && err.status === 404 ? `Job #${jobId} not found` : 'Could not load the job';
      setMessage(status, 'error', ...problemContent(asProblem(err, title)));
    }
  }
}

// Selects the machine of the job's tests in the sidebar (after a reload, say).
async function highlightMachineOf(job) {
  const id = job.request?.measurement_ids?.[0];
  if (!id) return;
  try {
    const m = await api.measurement(id);
    if (m.machine_id && m.machine_id !== ctx.getMachineId()) await ctx.selectMachine(m.machine_id);
  } catch {
    // The sidebar stays as it is; the job is shown anyway.
  }
}

function renderFailed(job) {
  const banner = h(
    'div',
    { class: 'verdict verdict-failed', role: 'alert', 'data-testid': 'disc-verdict', 'data-verdict': 'failed' },
    h('strong', { class: 'verdict-title' }, 'Discovery failed'),
    h('span', { class: 'verdict-detail problem-detail', 'data-testid': 'disc-error' }, job.error || 'no reason given'),
    h('span', { class: 'verdict-detail' }, 'No model and no figures: the study did not finish. Check the chosen tests and the machine model, then start it again.'),
  );
  $('#disc-result').replaceChildren(banner, actionsBox(job, null));
}

// ---------------------------------------------------------------- result

function verdictBanner(r) {
  const complete = r.verdict === 'complete';
  const misfit = r.verdict === 'model misfit';
  const figures = `Unexplained gap ${um(r.unexplained_rms_um)} µm RMS; noise floor ${um(r.noise_floor_um)} µm.`;
  const title = complete ? 'Complete' : misfit ? 'Model misfit' : `Verdict: ${r.verdict || 'none'}`;
  const say = complete
    ? 'The model with the effects found explains the tests down to the measurement noise.'
    : misfit
      ? 'The tests show an error that none of the candidate effects describes: the fitted values below are provisional.'
      : 'The study gave no clear verdict.';
  return h(
    'div',
    {
      class: `verdict ${complete ? 'verdict-complete' : misfit ? 'verdict-misfit' : 'verdict-unclear'}`,
      role: 'status',
      'data-testid': 'disc-verdict',
      'data-verdict': r.verdict || '',
    },
    h('strong', { class: 'verdict-title' }, title),
    h('span', { class: 'verdict-detail' }, say),
    h('span', { class: 'verdict-detail', 'data-testid': 'disc-stop-reason' }, `Stopped because ${r.stop_reason || 'no reason was given'}. ${figures}`),
  );
}

function summaryList(job, r) {
  const req = job.request || {};
  const base = baseGap(r);
  const items = [
    ['Machine', r.kind === 'hexapod' ? `hexapod ${r.machine_id || req.machine_id || ''}`.trim() : `serial${r.plane ? ` (${r.plane} plane)` : ''}`],
    ['Model', req.machine_id ? `${req.machine_id} version ${req.machine_version ?? '?'}` : 'none'],
    ['DBB tests', String((req.measurement_ids || []).length)],
    r.method ? ['Method', String(r.method).replace(/[-_]/g, ' ')] : null,
    ['Gap of the base model', `${um(base)} µm RMS`],
    ['Unexplained', `${um(r.unexplained_rms_um)} µm RMS`],
    ['Noise floor', `${um(r.noise_floor_um)} µm`],
    typeof r.condition_number === 'number' ? ['Condition number', plain(r.condition_number)] : null,
  ].filter(Boolean);
  return h(
    'dl',
    { class: 'disc-summary', 'data-testid': 'disc-summary' },
    ...items.map(([k, v]) => h('div', {}, h('dt', {}, k), h('dd', { 'data-key': k }, v))),
  );
}

function baseGap(r) {
  if (typeof r.base?.gap_rms_um === 'number') return r.base.gap_rms_um;
  if (Array.isArray(r.steps) && r.steps.length) return r.steps[0].gap_rms_before_um;
  return r.unexplained_rms_um;
}

function heldOut(ev) {
  const b = ev?.cv_press_before_um2;
  const a = ev?.cv_press_after_um2;
  if (typeof b !== 'number' || typeof a !== 'number' || !(b > 0)) return null;
  return { before: b, after: a, pct: 100 * (1 - a / b) };
}

// The analysis' sentence with its names in words: "(ramp_mm = 2)" → "(ramp length 2 mm)",
// "the fitted joint_friction" → "the fitted joint friction".
export function sentenceWords(text) {
  return String(text || '')
    .replace(/\b([A-Za-z][A-Za-z0-9]*(?:_[A-Za-z0-9]+)+)\s*=\s*(-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?)/g, (_, n, v) => variantWords(`${n} = ${v}`))
    .replace(/\b([a-z][a-z0-9]*(?:_[a-z0-9]+)+)\b/g, (n) => effectInText(n));
}

// Serial steps carry no sentence: the fitted value and the runner-up say what was found.
function evidenceText(step) {
  const ev = step.evidence || {};
  if (ev.sentence) return sentenceWords(ev.sentence);
  const parts = [];
  if (ev.value !== undefined) {
    const v = Array.isArray(ev.value)
      ? ev.value.map((x, i) => valuePm(x, Array.isArray(ev.sigma) ? ev.sigma[i] : ev.sigma)).join(', ')
      : valuePm(ev.value, ev.sigma);
    parts.push(`Fitted ${v}${ev.unit ? ` ${displayUnit(ev.unit)}` : ''}${typeof ev.z_score === 'number' ? ` (${fixedText(ev.z_score, 1)} σ from zero)` : ''}.`);
  }
  if (ev.runner_up) parts.push(`Next best candidate: ${effectWords(ev.runner_up)}.`);
  if (Array.isArray(ev.indistinguishable_from) && ev.indistinguishable_from.length) {
    parts.push(`Not distinguishable from ${ev.indistinguishable_from.map(effectWords).join(', ')}.`);
  }
  return parts.join(' ') || '—';
}

function stepsTable(r) {
  const steps = Array.isArray(r.steps) ? r.steps : [];
  const body = h('tbody');
  if (!steps.length) {
    body.append(h('tr', {}, h('td', { colspan: 6, class: 'text-left' }, 'No effect was added: the base model already explains the tests as well as any candidate.')));
  }
  steps.forEach((s, i) => {
    const ev = s.evidence || {};
    const ho = heldOut(ev);
    body.append(
      h(
        'tr',
        { 'data-step': i + 1, 'data-effect': s.added_effect },
        h('td', { class: 'num', 'data-key': 'step', 'data-label': 'Step' }, String(i + 1)),
        h('th', { scope: 'row', 'data-key': 'effect', 'data-step': i + 1 }, effectLabel(s.added_effect, ev.variant)),
        h(
          'td',
          { class: 'num', 'data-key': 'gap', 'data-label': 'Gap RMS (µm)' },
          h('span', { 'data-key': 'gap_rms_before_um' }, um(s.gap_rms_before_um)),
          ' → ',
          h('span', { 'data-key': 'gap_rms_after_um' }, um(s.gap_rms_after_um)),
        ),
        h('td', { class: 'evidence', 'data-key': 'sentence' }, evidenceText(s)),
        h('td', { class: 'num', 'data-key': 'p_value', 'data-label': 'p-value', 'data-log10-p': ev.log10_p_value ?? '' }, ...pValueNodes(ev.p_value, ev.log10_p_value)),
        h(
          'td',
          { class: 'num', 'data-key': 'held_out', 'data-label': 'Held-out prediction error', 'data-pct': ho ? ho.pct : '' },
          ho
            ? [
                h('span', { class: 'held-out-pct' }, `${ho.pct >= 0 ? '−' : '+'}${pct(Math.abs(ho.pct))}`),
                h('span', { class: 'held-out-press' }, `${plain(ho.before)} → ${plain(ho.after)} µm²`),
              ]
            : h('span', { title: 'the serial study does not score held-out tests' }, '—'),
        ),
      ),
    );
  });
  return h(
    'table',
    { class: 'figures small disc-steps stack-narrow', 'data-testid': 'disc-steps' },
    h('caption', {}, 'Steps: the effect added at each step and why'),
    h(
      'thead',
      {},
      h(
        'tr',
        {},
        h('th', { scope: 'col', class: 'num' }, 'Step'),
        h('th', { scope: 'col' }, 'Effect added'),
        h('th', { scope: 'col', class: 'num' }, 'Gap RMS before → after (µm)'),
        h('th', { scope: 'col' }, 'Evidence'),
        h('th', { scope: 'col', class: 'num', title: 'F-test of the fit with the effect against the fit without it' }, 'p-value'),
        h('th', { scope: 'col', class: 'num', title: 'Change of the prediction error on held-out tests (cross-validated PRESS)' }, 'Held-out prediction error'),
      ),
    ),
    body,
  );
}

function candidateOutcome(c, chosen) {
  if (chosen) return 'added';
  if (c.qualified) return 'qualified, not the best';
  return c.rejected_because ? `rejected: ${c.rejected_because}` : 'rejected';
}

// Every candidate tried at every step (hexapod study), and those left at the stop.
function candidatesBox(r) {
  const steps = Array.isArray(r.steps) ? r.steps : [];
  const rows = [];
  steps.forEach((s, i) => {
    const ev = s.evidence || {};
    for (const c of Array.isArray(ev.candidates) ? ev.candidates : []) {
      const chosen = c.effect === s.added_effect && (c.variant || '') === (ev.variant || '');
      rows.push({ step: String(i + 1), c, chosen });
    }
  });
  for (const c of Array.isArray(r.candidates_at_stop) ? r.candidates_at_stop : []) rows.push({ step: 'stop', c, chosen: false });
  if (!rows.length) return null;
  return h(
    'details',
    { class: 'disc-more', 'data-testid': 'disc-candidates' },
    h('summary', {}, `Candidates tried (${rows.length})`),
    h(
      'div',
      { class: 'table-scroll' },
      h(
        'table',
        { class: 'figures small' },
        h(
          'thead',
          {},
          h(
            'tr',
            {},
            h('th', { scope: 'col', class: 'num' }, 'Step'),
            h('th', { scope: 'col' }, 'Candidate'),
            h('th', { scope: 'col', class: 'num' }, 'p-value'),
            h('th', { scope: 'col', class: 'num' }, 'Held-out PRESS (µm²)'),
            h('th', { scope: 'col' }, 'Outcome'),
          ),
        ),
        h(
          'tbody',
          {},
          ...rows.map(({ step, c, chosen }) =>
            h(
              'tr',
              { class: chosen ? 'chosen' : c.qualified ? '' : 'rejected', 'data-step': step, 'data-effect': c.effect },
              h('td', { class: 'num' }, step),
              h('th', { scope: 'row' }, effectLabel(c.effect, c.variant)),
              h('td', { class: 'num' }, ...pValueNodes(c.p_value, c.log10_p_value)),
              h('td', { class: 'num' }, plain(c.cv_press_um2)),
              h('td', {}, candidateOutcome(c, chosen)),
            ),
          ),
        ),
      ),
    ),
  );
}

// Bars: the gap of the base model, then after each step; the noise floor as a dashed line.
export function renderGapChart(bars, noiseFloor, { title = 'Gap between model and tests, step by step', narrow = false } = {}) {
  // Narrow screens get a narrower drawing, so that its text stays readable when scaled down.
  const W = narrow ? 370 : 560;
  const L = 14;
  const R = 104;
  const T = 12;
  const ROW = 50;
  const NOTE = 22; // the noise-floor label, under the last bar
  const B = 52;
  const H = T + ROW * bars.length + NOTE + B;
  const hasFloor = typeof noiseFloor === 'number' && Number.isFinite(noiseFloor);
  const hiData = Math.max(...bars.map((b) => b.gap), hasFloor ? noiseFloor : 0, 1e-3);
  const xt = ticks(0, hiData, 5);
  const hi = Math.max(hiData, xt.values[xt.values.length - 1]);
  const px = (v) => L + (v / hi) * (W - L - R);
  const svg = el('svg', {
    viewBox: `0 0 ${W} ${H}`,
    width: W,
    height: H,
    role: 'img',
    class: 'chart bars gap-chart',
    'data-testid': 'disc-gap-chart',
    'data-noise-floor-um': hasFloor ? noiseFloor : '',
    'data-px-per-um': (W - L - R) / hi,
    'data-zero-px': L,
    'aria-label':
      `${title}: ${bars.map((b) => `${b.label} ${b.gap.toFixed(3)} µm`).join('; ')}` +
      `${hasFloor ? `; noise floor ${noiseFloor.toFixed(3)} µm` : ''}.`,
  });
  svg.append(el('title', {}, title));
  svg.append(axesGrid({ W, H, L, R, T, B, px, py: (v) => v, xt, yt: { values: [], step: 1 } }));
  svg.append(el('text', { x: r2(L + (W - L - R) / 2), y: H - 10, 'text-anchor': 'middle', class: 'axis-title' }, 'Gap RMS (µm)'));
  // Layers: bars, the noise-floor line over them, the labels (with a white halo) on top.
  const g = el('g', { class: 'gap-bars' });
  const labels = el('g', { class: 'gap-labels' });
  bars.forEach((b, i) => {
    const y = T + i * ROW;
    const w = Math.max(1, px(b.gap) - L);
    const bar = el('g', {
      class: `bar${b.step === 0 ? ' base' : ''}`,
      'data-step': b.step,
      'data-effect': b.effect || '',
      'data-gap-um': b.gap,
    });
    bar.append(el('rect', { x: L, y: y + 23, width: r2(w), height: 20, rx: 2 }));
    g.append(bar);
    labels.append(el('text', { x: L + 4, y: y + 16, class: 'bar-label', 'data-step': b.step }, b.label));
    labels.append(el('text', { x: r2(L + w + 6), y: y + 38, class: 'bar-value', 'data-step': b.step }, `${b.gap.toFixed(3)} µm`));
  });
  svg.append(g);
  if (hasFloor) {
    const x = r2(px(noiseFloor));
    const yEnd = T + ROW * bars.length + NOTE;
    svg.append(el('line', { x1: x, x2: x, y1: T, y2: yEnd, class: 'noise-floor', 'data-testid': 'disc-noise-floor', 'data-um': noiseFloor }));
    const label = `noise floor ${noiseFloor.toFixed(3)} µm`;
    const right = x + 8 + label.length * 7.5 < W - 4;
    labels.append(el('text', { x: right ? x + 6 : x - 6, y: yEnd - 6, 'text-anchor': right ? 'start' : 'end', class: 'noise-label' }, label));
  }
  svg.append(labels);
  return svg;
}

function gapChartBox(r) {
  const steps = Array.isArray(r.steps) ? r.steps : [];
  const bars = [
    { step: 0, effect: '', label: r.kind === 'hexapod' ? 'Base model (kinematic parameters)' : 'Base model', gap: baseGap(r) },
    ...steps.map((s, i) => ({ step: i + 1, effect: s.added_effect, label: `Step ${i + 1}: + ${effectWords(s.added_effect)}`, gap: s.gap_rms_after_um })),
  ].filter((b) => typeof b.gap === 'number' && Number.isFinite(b.gap));
  const fig = h('figure', { class: 'chart-box gap-chart-box' });
  const narrow = window.matchMedia ? window.matchMedia('(max-width: 640px)').matches : false;
  fig.append(renderGapChart(bars, r.noise_floor_um, { narrow }));
  fig.append(h('figcaption', {}, 'RMS of the difference between the tests and the model, after each step; the dashed line is the noise floor of the tests (below it nothing more can be explained).'));
  return fig;
}

// Gap RMS of every test: base model, then after each step (hexapod results carry them).
function testGapsBox(r) {
  const steps = Array.isArray(r.steps) ? r.steps : [];
  const base = Array.isArray(r.base?.tests) ? r.base.tests : [];
  if (!base.length) return null;
  const key = (t) => `${t.file ?? ''}|${t.test_id ?? ''}|${t.direction ?? ''}`;
  const after = steps.map((s) => {
    const m = new Map();
    (Array.isArray(s.tests) ? s.tests : []).forEach((t, i) => {
      m.set(key(t), t.gap_rms_after_um);
      m.set(`#${i}`, t.gap_rms_after_um);
    });
    return m;
  });
  const fileText = (f) => {
    const m = String(f || '').match(/^measurement (\d+)$/);
    return m ? `#${m[1]}` : String(f || '').split('/').pop();
  };
  return h(
    'details',
    { class: 'disc-more', 'data-testid': 'disc-test-gaps' },
    h('summary', {}, `Gap of each test at each step (${base.length} tests)`),
    h(
      'div',
      { class: 'table-scroll' },
      h(
        'table',
        { class: 'figures small disc-test-table' },
        h('caption', {}, 'Gap RMS per test (µm): base model, then after each step'),
        h(
          'thead',
          {},
          h(
            'tr',
            {},
            h('th', { scope: 'col' }, 'Test'),
            h('th', { scope: 'col' }, 'Direction'),
            h('th', { scope: 'col' }, 'Measurement'),
            h('th', { scope: 'col', class: 'num' }, 'Base'),
            ...steps.map((s, i) => h('th', { scope: 'col', class: 'num', 'data-step': i + 1 }, `+ ${effectWords(s.added_effect)}`)),
          ),
        ),
        h(
          'tbody',
          {},
          ...base.map((t, i) =>
            h(
              'tr',
              { 'data-test-id': t.test_id, 'data-direction': t.direction },
              h('th', { scope: 'row' }, t.test_id ?? '—'),
              h('td', {}, formatDirection(t.direction)),
              h('td', { class: 'col-id' }, fileText(t.file)),
              h('td', { class: 'num', 'data-step': 0 }, um(t.gap_rms_before_um)),
              ...after.map((m, k) => {
                const v = m.has(key(t)) ? m.get(key(t)) : m.get(`#${i}`);
                return h('td', { class: 'num', 'data-step': k + 1 }, um(v));
              }),
            ),
          ),
        ),
      ),
    ),
  );
}

function kinematicTable(entry) {
  const p = entry.parameters || {};
  const u = entry.uncertainty || {};
  const fixed = new Set(Array.isArray(entry.fixed_parameters) ? entry.fixed_parameters : []);
  const cell = (name, v, s) =>
    h(
      'td',
      { class: `num${fixed.has(name) ? ' fixed' : ''}`, 'data-param': name, title: fixed.has(name) ? 'fixed (not identifiable from these tests)' : null },
      fixed.has(name) ? `${um(v)} (fixed)` : `${um(v)} ± ${um(s)}`,
    );
  return h(
    'table',
    { class: 'figures small disc-kinematic', 'data-testid': 'disc-kinematic' },
    h('caption', {}, 'Kinematic parameters: strut length offsets and base-joint position errors (µm, ± standard uncertainty)'),
    h(
      'thead',
      {},
      h(
        'tr',
        {},
        h('th', { scope: 'col' }, 'Strut'),
        h('th', { scope: 'col', class: 'num' }, 'Length offset'),
        h('th', { scope: 'col', class: 'num' }, 'Base joint X'),
        h('th', { scope: 'col', class: 'num' }, 'Base joint Y'),
        h('th', { scope: 'col', class: 'num' }, 'Base joint Z'),
      ),
    ),
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
}

// Hexapod effects: one row per parameter, in words and human units.
function effectsTable(entries) {
  const rows = [];
  for (const e of entries) {
    const params = Object.entries(e.parameters || {});
    const fixed = new Set(Array.isArray(e.fixed_parameters) ? e.fixed_parameters : []);
    params.forEach(([name, value], i) => {
      const w = parameterWords(name);
      const sigma = e.uncertainty?.[name];
      const isFixed = fixed.has(name);
      const shown = typeof value === 'number' ? value * w.factor : value;
      rows.push(
        h(
          'tr',
          { 'data-effect': e.effect, 'data-param': name, class: isFixed ? 'fixed-row' : '' },
          i === 0 ? h('th', { scope: 'rowgroup', rowspan: params.length, class: 'effect-cell' }, effectWords(e.effect)) : null,
          h('td', { class: 'param-name' }, w.label),
          h(
            'td',
            { class: `num${isFixed ? ' fixed' : ''}`, 'data-key': 'value' },
            isFixed ? `${plain(shown)} (held at the machine file's value)` : valuePm(shown, typeof sigma === 'number' ? sigma * w.factor : null),
          ),
          h('td', { class: 'unit' }, w.unit),
        ),
      );
    });
  }
  return h(
    'table',
    { class: 'figures small disc-effects stack-narrow', 'data-testid': 'disc-effects' },
    h('caption', {}, 'Effects found (± standard uncertainty)'),
    h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Effect'), h('th', { scope: 'col' }, 'Parameter'), h('th', { scope: 'col', class: 'num' }, 'Value'), h('th', { scope: 'col', class: 'unit' }, 'Unit'))),
    h('tbody', {}, ...rows),
  );
}

// Serial final model: {effect, value (number or [x, y]), unit, sigma}.
function serialModelTable(entries) {
  const text = (e) => {
    if (Array.isArray(e.value)) {
      const axes = ['X', 'Y', 'Z'];
      return e.value.map((v, i) => `${axes[i] || i + 1} ${valuePm(v, Array.isArray(e.sigma) ? e.sigma[i] : e.sigma)}`).join(', ');
    }
    return valuePm(e.value, e.sigma);
  };
  return h(
    'table',
    { class: 'figures small disc-effects', 'data-testid': 'disc-effects' },
    h('caption', {}, 'Effects found (± standard uncertainty)'),
    h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Effect'), h('th', { scope: 'col', class: 'num' }, 'Value'), h('th', { scope: 'col', class: 'unit' }, 'Unit'))),
    h(
      'tbody',
      {},
      ...entries.map((e) =>
        h('tr', { 'data-effect': e.effect }, h('th', { scope: 'row' }, effectWords(e.effect)), h('td', { class: 'num', 'data-key': 'value' }, text(e)), h('td', { class: 'unit' }, displayUnit(e.unit))),
      ),
    ),
  );
}

function finalModelBox(r) {
  const model = Array.isArray(r.final_model) ? r.final_model : [];
  const box = h('section', { class: 'disc-block', 'data-testid': 'disc-final-model', 'aria-labelledby': 'disc-final-heading' }, h('h3', { id: 'disc-final-heading' }, 'Final model'));
  if (r.kind === 'hexapod') {
    const kin = model.find((e) => e.effect === 'kinematic_parameters');
    const effects = model.filter((e) => e.effect !== 'kinematic_parameters');
    if (effects.length) box.append(h('div', { class: 'table-scroll' }, effectsTable(effects)));
    else box.append(h('p', { class: 'note' }, 'No effect beyond the kinematic parameters.'));
    if (kin) box.append(h('div', { class: 'table-scroll' }, kinematicTable(kin)));
  } else if (model.length) {
    box.append(h('div', { class: 'table-scroll' }, serialModelTable(model)));
  } else {
    box.append(h('p', { class: 'note' }, 'No effect was identified.'));
  }
  const extra = [];
  if (Array.isArray(r.not_identifiable) && r.not_identifiable.length) extra.push(`Not identifiable from these tests: ${r.not_identifiable.map((x) => effectWords(x)).join(', ')}.`);
  if (Array.isArray(r.rejected) && r.rejected.length) extra.push(`Rejected: ${r.rejected.map(sentenceWords).join('; ')}.`);
  for (const t of extra) box.append(h('p', { class: 'note muted-note' }, t));
  return box;
}

function compensationBox(r) {
  const c = r.compensation;
  if (!c || !Array.isArray(c.tests) || !c.tests.length) return null;
  const effects = (c.compensated_effects || []).map((e) => effectWords(e).toLowerCase());
  return h(
    'section',
    { class: 'disc-block', 'data-testid': 'disc-compensation', 'aria-labelledby': 'disc-comp-heading' },
    h('h3', { id: 'disc-comp-heading' }, 'Compensation preview'),
    h('p', { class: 'note' }, `Circularity of each test as measured, and as predicted with the command corrected for ${effects.join(' and ') || 'the effects found'} (as [PM-600 report] table 4.5).`),
    h(
      'div',
      { class: 'table-scroll' },
      h(
        'table',
        { class: 'figures small disc-comp' },
        h(
          'thead',
          {},
          h(
            'tr',
            {},
            h('th', { scope: 'col' }, 'Test'),
            h('th', { scope: 'col' }, 'Direction'),
            h('th', { scope: 'col', class: 'num' }, 'Circularity without compensation (µm)'),
            h('th', { scope: 'col', class: 'num' }, 'Predicted with compensation (µm)'),
            h('th', { scope: 'col', class: 'num' }, 'Change'),
          ),
        ),
        h(
          'tbody',
          {},
          ...c.tests.map((t) => {
            const a = t.circularity_without_compensation_um;
            const b = t.predicted_circularity_with_compensation_um;
            const change = typeof a === 'number' && typeof b === 'number' && a > 0 ? (100 * (b - a)) / a : null;
            return h(
              'tr',
              { 'data-test-id': t.test_id, 'data-direction': t.direction },
              h('th', { scope: 'row' }, t.test_id ?? '—'),
              h('td', {}, formatDirection(t.direction)),
              h('td', { class: 'num', 'data-key': 'circularity_without_compensation_um' }, um(a)),
              h('td', { class: 'num', 'data-key': 'predicted_circularity_with_compensation_um' }, um(b)),
              h('td', { class: 'num', 'data-key': 'change' }, change === null ? '—' : `${change > 0 ? '+' : change < 0 ? '−' : ''}${pct(Math.abs(change))}`),
            );
          }),
        ),
      ),
    ),
  );
}

// Save the updated machine as a new model version; download the result JSON.
function actionsBox(job, r) {
  const box = h('div', { class: 'disc-actions', 'data-testid': 'disc-actions' });
  const status = h('div', { class: 'message', 'data-testid': 'disc-save-status', 'aria-live': 'polite', hidden: true });
  if (r && r.updated_machine) {
    const button = h(
      'button',
      {
        type: 'button',
        'data-testid': 'disc-save',
        onclick: async () => {
          button.disabled = true;
          setMessage(status, 'info', 'Saving…');
          try {
            const out = await api.saveJobMachine(job.id);
            status.dataset.version = out.version;
            status.dataset.machineId = out.machine_id;
            setMessage(
              status,
              'success',
              h('strong', { class: 'problem-title' }, out.created ? `Saved as ${out.machine_id} version ${out.version}` : `Already stored as ${out.machine_id} version ${out.version}`),
              h('span', {}, out.created ? 'New discoveries and calibrations can start from this version.' : 'The newest version holds the same machine: nothing new was stored.'),
            );
            await ctx.reloadMachines();
          } catch (err) {
            if (!ctx.handleAuth(err)) setMessage(status, 'error', ...problemContent(asProblem(err, 'Not saved')));
          } finally {
            button.disabled = false;
          }
        },
      },
      'Save as new machine model version',
    );
    box.append(button);
  } else if (r) {
    box.append(h('span', { class: 'note' }, r.kind === 'hexapod' ? 'This job produced no machine model to save.' : 'A serial study produces no machine model to save.'));
  }
  if (r) {
    if (state.jsonUrl) URL.revokeObjectURL(state.jsonUrl);
    state.jsonUrl = URL.createObjectURL(new Blob([`${JSON.stringify(r, null, 2)}\n`], { type: 'application/json' }));
    box.append(h('a', { class: 'button-link secondary-link', href: state.jsonUrl, download: `kinemetric-discovery-job-${job.id}.json`, 'data-testid': 'disc-download' }, 'Download result (JSON)'));
  }
  box.append(h('a', { class: 'button-link secondary-link', href: newFormHash(ctx.getMachineId()) }, 'New discovery'));
  return h('div', {}, box, status);
}

function renderResult(job) {
  const r = job.result || {};
  const box = $('#disc-result');
  const parts = [
    verdictBanner(r),
    summaryList(job, r),
    h(
      'section',
      { class: 'disc-block', 'aria-labelledby': 'disc-steps-heading' },
      h('h3', { id: 'disc-steps-heading' }, 'How the gap shrank'),
      gapChartBox(r),
      h('div', { class: 'table-scroll' }, stepsTable(r)),
      candidatesBox(r),
      testGapsBox(r),
    ),
    finalModelBox(r),
    compensationBox(r),
    actionsBox(job, r),
  ];
  box.replaceChildren(...parts.filter(Boolean));
  box.dataset.jobId = job.id;
}

// ---------------------------------------------------------------- start

export function initDiscovery(callbacks) {
  Object.assign(ctx, callbacks);
  $('#disc-form').addEventListener('submit', onSubmit);
  $('#disc-all').addEventListener('click', () => setAllChecks(true));
  $('#disc-none').addEventListener('click', () => setAllChecks(false));
  $('#disc-model').addEventListener('change', () => loadVersions());
  $('#disc-store').addEventListener('click', onStoreModel);
  $('#discovery-close').addEventListener('click', leaveDiscovery);
}

// The list of machines changed (a model was stored): the model choice follows.
export function discoveryMachinesChanged() {
  if (parseRoute().view === 'discovery-new' && state.formMachine) loadModels($('#disc-model').value || undefined);
}
