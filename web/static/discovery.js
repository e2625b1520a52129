// Model-gap discovery page ([PM-600 report] ch. 4–5): start a discovery study of a machine's DBB
// tests against a stored machine model (or none: the serial study), follow the background job
// (step and candidate being tried) and show its result — verdict, the steps with their evidence,
// the gap shrinking step by step down to the noise floor, the gap of every test at every step,
// the final model with its uncertainties, the compensation preview ([PM-600 report] table 4.5),
// saving the updated machine as a new model version, and the result JSON.
//
// Addresses: #/discoveries?machine=ID (the start form) and #/discoveries/JOB_ID (one job), so a
// reload keeps the page. The result is the JSON of `kinemetric discover --json`
// (usecases/discovery_json.cpp); the job is served by GET /api/v1/jobs/{id}. The result is drawn by
// discovery_result.js, its words and numbers are discovery_words.js.

import { JOB_STATUS } from './contract.js';
import { api, ApiError } from './api.js';
import { $, asProblem, errorBox, h, problemContent, setMessage } from './dom.js';
import { ctx, newFormHash } from './discovery_ctx.js';
import { renderFailed, renderResult } from './discovery_result.js';
import { effectInText } from './discovery_words.js';
import { formatDirection, formatTimestamp } from './format.js';
import { cancelledContent, jobCancelControl } from './job_cancel.js';
import { pollJob, selectMachineOfJob } from './job_poll.js';
import { hideCertificate, showJobCertificate } from './reports.js';

// The engine's default maximum number of steps (analysis/discovery/engine.h, EngineOptions): the
// job reports its progress as step / (max_steps + 1). Used only when the stage text does not
// name the step.
const ENGINE_MAX_STEPS = 8;
const JOB_LIST_LIMIT = 200;

const state = {
  route: { view: 'detail' },
  seq: 0, // a new route stops the polling / rendering of the previous one
  checked: new Map(), // machine id → Set of ticked DBB measurement ids
  formMachine: null,
  models: [], // machines with a stored model: [{machine_id, model_versions}]
  jobs: [], // discovery jobs of the selected machine (list, without results)
  jobsMachine: null, // the machine state.jobs belongs to
  jobsSeq: 0,
  planes: new Map(), // measurement id → the plane of its DBB test (XY, YZ, ZX; '' unknown)
  modelKinds: new Map(), // machine id → the kind of its stored model (hexapod, serial, …)
};

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
  $('#discovery-new-role').hidden = route.view !== 'discovery-new';
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

// The plane of each DBB test (its results say it; a measurement never changes, so once read it is
// kept) and the kind of the machine's own stored model: what the default choice and the check
// before submitting need. Resolves when both are known.
async function readPlanes(machineId, tests) {
  const missing = tests.filter((m) => !state.planes.has(m.id));
  const one = (m) =>
    api.results(m.id).then(
      (r) => state.planes.set(m.id, String((r && r.plane) || 'XY').toUpperCase()),
      (err) => (err instanceof ApiError && (err.status === 401 || err.status === 403) ? Promise.reject(err) : state.planes.set(m.id, '')),
    );
  for (let i = 0; i < missing.length; i += 6) await Promise.all(missing.slice(i, i + 6).map(one));
  const own = ctx.getMachines().find((m) => m.machine_id === machineId);
  if (own && (own.model_versions || 0) > 0) await modelKind(machineId);
}

async function modelKind(machineId) {
  if (!state.modelKinds.has(machineId)) {
    const def = await api.machineDefinition(machineId).catch(() => null);
    state.modelKinds.set(machineId, (def && def.kind) || '');
  }
  return state.modelKinds.get(machineId);
}

// A serial study (no model, or a model that is not a hexapod) fits the tests of one plane.
const isSerial = (kind) => kind !== 'hexapod';
const planeOf = (m) => state.planes.get(m.id) || '';

// The ticked tests of a machine; by default the newest test of each set-up (test and
// direction): every set-up counts (the study scores candidates on held-out tests, so more
// set-ups make it stronger), while older repeats — a machine measured before a repair — would mix
// two states of the machine into one model. A serial study fits one plane: then only the set-ups
// of the plane of the machine's newest test. Remembered once the machine's tests are in.
function checkedSet(machineId) {
  const known = state.checked.get(machineId);
  if (known) return known;
  let dbb = dbbOfMachine();
  const newest = new Map();
  const when = (m) => m.timestamp || m.uploaded_at || '';
  const own = ctx.getMachines().find((m) => m.machine_id === machineId);
  const ownKind = own && (own.model_versions || 0) > 0 ? state.modelKinds.get(machineId) : '';
  if (dbb.length && isSerial(ownKind)) {
    const last = dbb.reduce((a, b) => (when(b) > when(a) || (when(b) === when(a) && b.id > a.id) ? b : a));
    dbb = dbb.filter((m) => planeOf(m) === planeOf(last));
  }
  for (const m of dbb) {
    const key = `${m.test_id}\u0000${m.direction}`;
    const cur = newest.get(key);
    if (!cur || when(m) > when(cur) || (when(m) === when(cur) && m.id > cur.id)) newest.set(key, m);
  }
  const set = new Set([...newest.values()].map((m) => m.id));
  if (dbbOfMachine().length) state.checked.set(machineId, set);
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
  if (state.formMachine !== machineId) {
    state.formMachine = machineId;
    setMessage($('#disc-form-status'), null);
    loadModels();
  }
  const box = $('#disc-measurements');
  if (dbb.some((m) => !state.planes.has(m.id)) || (!state.checked.has(machineId) && !planesReady(machineId))) {
    box.dataset.planes = 'loading';
    box.replaceChildren(h('p', { class: 'placeholder' }, 'Reading the planes of the tests…'));
    $('#disc-count').textContent = '';
    readPlanes(machineId, dbb).then(
      () => {
        if (parseRoute().view === 'discovery-new' && ctx.getMachineId() === machineId) renderForm();
      },
      (err) => ctx.handleAuth(err),
    );
    return;
  }
  box.dataset.planes = 'ready';
  const known = new Set(dbb.map((m) => m.id));
  const checked = checkedSet(machineId);
  for (const id of [...checked]) if (!known.has(id)) checked.delete(id);
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
              'data-plane': planeOf(m),
              checked: checked.has(m.id),
              onchange: (e) => {
                if (e.target.checked) checked.add(m.id);
                else checked.delete(m.id);
                updateCount();
              },
            }),
            h('span', {}, `${m.test_id || m.filename || `#${m.id}`}`),
            m.direction ? h('span', { class: `badge dir-${m.direction}` }, formatDirection(m.direction)) : '',
            planeOf(m) ? h('span', { class: 'badge plane', 'data-testid': 'disc-plane', title: 'plane of the circle' }, planeOf(m)) : '',
            // The note above the list says the times are UTC.
            h('span', { class: 'item-meta' }, `#${m.id}`, m.timestamp || m.uploaded_at ? ` · ${formatTimestamp(m.timestamp || m.uploaded_at, { zone: false })}` : '', m.filename ? ` · ${m.filename}` : ''),
          );
        })
      : [h('p', { class: 'placeholder' }, 'This machine has no DBB tests.')]),
  );
  updateCount();
}

// The kind of the machine's own model is known (or it has none).
function planesReady(machineId) {
  const own = ctx.getMachines().find((m) => m.machine_id === machineId);
  return !(own && (own.model_versions || 0) > 0) || state.modelKinds.has(machineId);
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

// The chosen tests grouped by plane, in words, when they are in more than one plane; else null.
function planesOfChoice(ids) {
  const byPlane = new Map();
  for (const id of ids) {
    const p = state.planes.get(id) || 'unknown plane';
    byPlane.set(p, [...(byPlane.get(p) || []), id]);
  }
  if (byPlane.size < 2) return null;
  const groups = [...byPlane].map(([p, list]) => `${p} (${list.map((i) => `#${i}`).join(', ')})`);
  return `A study without a hexapod model fits the tests of one plane; the chosen tests are in ${groups.join(' and ')}. Untick the tests of all planes but one.`;
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
  const mixed = isSerial(model ? await modelKind(model) : '') ? planesOfChoice(ids) : null;
  if (mixed) {
    setMessage(status, 'error', h('strong', { class: 'problem-title', 'data-testid': 'disc-planes-refused' }, 'Tests in more than one plane'), h('span', { class: 'problem-detail' }, mixed), h('span', { class: 'problem-where' }, 'field “plane”'));
    return;
  }
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
      h('span', { 'data-testid': 'disc-stage' }, stageWords(job.stage) || (job.status === JOB_STATUS.queued ? 'waiting for the worker' : '')),
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

let showCancel = () => {}; // the view's Cancel button (initDiscovery)

async function showJob(jobId, seq) {
  showCancel(null);
  hideCertificate('disc'); // asked once the job has ended
  const status = $('#disc-status');
  const result = $('#disc-result');
  result.replaceChildren();
  status.dataset.jobId = jobId;
  delete status.dataset.status;
  setMessage(status, 'info', `Loading job #${jobId}…`);
  $('#discovery-sub').textContent = '';
  let highlighted = false;
  const shown = (job) => {
    setMessage(status, null);
    if (job.status === JOB_STATUS.done) renderResult(job);
    else renderFailed(job);
    bringIntoView();
  };
  await pollJob(jobId, {
    current: () => seq === state.seq,
    show: (job) => {
      if (job.kind !== 'discovery') {
        setMessage(status, 'error', h('strong', { class: 'problem-title' }, `Job #${jobId} is not a discovery`), h('span', { class: 'problem-detail' }, `It is a ${String(job.kind).replace(/_/g, ' ')} job.`));
        return false;
      }
      $('#discovery-sub').textContent = requestSummary(job);
      // What the view shows, for tests and links: the job and the server's verdict on it.
      $('#discovery').dataset.jobId = String(jobId);
      $('#discovery').dataset.jobVerdict = job.verdict || '';
      if (!highlighted) {
        highlighted = true;
        selectMachineOfJob(job);
      }
      status.dataset.status = job.status;
      showCancel(job);
      return true;
    },
    ended: (job) => {
      if (job.status === JOB_STATUS.cancelled) setMessage(status, 'info', ...cancelledContent(job));
      else shown(job);
      showJobCertificate('disc', job);
      refreshDiscoveryList();
    },
    waiting: (job) => setMessage(status, 'info', ...jobStatusContent(job)),
    failedToLoad: (err) => {
      if (!ctx.handleAuth(err)) {
        const title = err instanceof ApiError && err.status === 404 ? `Job #${jobId} not found` : 'Could not load the job';
        setMessage(status, 'error', ...problemContent(asProblem(err, title)));
      }
    },
  });
}

// ---------------------------------------------------------------- start

export function initDiscovery() {
  $('#disc-form').addEventListener('submit', onSubmit);
  $('#disc-all').addEventListener('click', () => setAllChecks(true));
  $('#disc-none').addEventListener('click', () => setAllChecks(false));
  $('#disc-model').addEventListener('change', () => loadVersions());
  $('#disc-store').addEventListener('click', onStoreModel);
  // Back to the machine's measurements (its newest DBB test), not to an empty view.
  $('#discovery-close').addEventListener('click', () => {
    const id = ctx.getMachineId();
    window.location.hash = id ? `#/machines/${encodeURIComponent(id)}` : '#/';
  });
  showCancel = jobCancelControl($('#disc-cancel'), $('#disc-cancel-status'));
}

// The list of machines changed (a model was stored): the model choice follows.
export function discoveryMachinesChanged() {
  if (parseRoute().view === 'discovery-new' && state.formMachine) loadModels($('#disc-model').value || undefined);
}
