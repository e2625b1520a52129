// kinemetric dashboard: machines → measurements (paged, filtered) → DBB polar plot, figures and
// diagnosis of the pair the server analyses; form and tracker plots; calibration jobs with the
// server's verdict; uploads; streams. Each view has its address (router.js); the model-gap
// discovery page (#/discoveries…) is discovery.js.
// Plain ES modules, no build step, nothing loaded from outside the server. One module a view:
// machines.js, measurements.js, detail.js (figures.js, diagnosis.js, formplots.js),
// calibration.js, upload.js, streams.js, discovery.js, fleet.js (fleet and trends), audit.js
// (a machine's audit; audit_form.js its rules), tokens.js (tokens, audit log), home.js (the
// landing view); DOM helpers in dom.js.

import { getToken, setToken, takeTokenFromFragment } from './api.js';
import { handleAuth, showAuthProblem, tokenChanged, updateTokenStatus } from './auth.js';
import { initCalibration, loadJobHistory, resetCalibration, showJob } from './calibration.js';
import { initDetail, resetDetail, showMeasurement } from './detail.js';
import { $, h } from './dom.js';
import { applyRoute as applyDiscoveryRoute, initDiscovery } from './discovery.js';
import { loadMachines, renderMachines, selectMachine } from './machines.js';
import { initMeasurementList } from './measurements.js';
import { parseAppRoute } from './router.js';
import { shell } from './shell.js';
import { state } from './state.js';
import { initFleet, showFleet, showTrends } from './fleet.js';
import { initAudit, resetAuditSummary, showAudit } from './audit.js';
import { showHome } from './home.js';
import { initTokens, showTokens } from './tokens.js';
import { initReports } from './reports.js';
import { forgetRole, loadRole } from './roles.js';
import { initServo, resetJointHealth } from './servo.js';
import { initStreams, refreshStreams } from './streams.js';
import { initUpload } from './upload.js';

// Which main view is shown: the measurement view (#detail), a calibration job (#job-view) or the
// discovery page (#discovery, shown by discovery.js).
const MAIN_VIEWS = { detail: '#detail', job: '#job-view', fleet: '#fleet-view', trends: '#trends-view', home: '#home-view', audit: '#audit-view', tokens: '#tokens-view' };
let shownView = null;

function showMainView(which) {
  shownView = which;
  for (const [name, sel] of Object.entries(MAIN_VIEWS)) $(sel).hidden = which !== name;
  if (which !== 'discovery') $('#discovery').hidden = true;
}

// A machine the server does not know: said on the landing view (the list is reloaded first, in
// case it was uploaded meanwhile). True when it is known.
async function knownMachine(machineId) {
  if (!state.machines.some((m) => m.machine_id === machineId)) await loadMachines();
  if (state.machines.some((m) => m.machine_id === machineId)) return true;
  showMainView('home');
  resetAuditSummary();
  await showHome(`No machine “${machineId}” is stored. Choose one under Machines, or upload its measurements.`);
  return false;
}

// Shows what the address names; called at start and on every hashchange.
let routeSeq = 0; // a newer address overrides what an older one was still loading

async function applyRoute() {
  const seq = ++routeSeq;
  const route = parseAppRoute();
  document.body.dataset.route = route.view;
  if (route.view === 'anchor') {
    if (!shownView) await applyHome(null);
    return;
  }
  if (route.view === 'discovery') {
    for (const sel of Object.values(MAIN_VIEWS)) if (sel !== '#detail') $(sel).hidden = true;
    shownView = 'discovery';
    applyDiscoveryRoute();
    return;
  }
  applyDiscoveryRoute(); // leaves the discovery page, keeps its sidebar list current
  if (route.view === 'job') {
    showMainView('job');
    await showJob(route.jobId);
    return;
  }
  if (route.view === 'fleet') {
    showMainView('fleet');
    await showFleet();
    return;
  }
  if (route.view === 'trends') {
    showMainView('trends');
    await showTrends(route.machineId, route.metric);
    return;
  }
  if (route.view === 'tokens') {
    showMainView('tokens');
    await showTokens();
    return;
  }
  if (route.view === 'home' || route.view === 'unknown') {
    await applyHome(route.view === 'unknown' ? `The address “#${route.address}” names no view of this page.` : null);
    return;
  }
  if (route.view === 'audit') {
    if (!(await knownMachine(route.machineId))) return;
    showMainView('audit');
    await Promise.all([showAudit(route.machineId), selectMachine(route.machineId)]);
    return;
  }
  if (route.view === 'measurement') {
    showMainView('detail');
    await showMeasurement(route.id);
    return;
  }
  const machineId = route.machineId;
  if (!(await knownMachine(machineId))) return;
  showMainView('detail');
  const items = await selectMachine(machineId);
  if (seq !== routeSeq) return;
  // The machine's newest DBB test on this page (else its newest measurement).
  if (state.measurementId && items.some((m) => m.id === state.measurementId)) return;
  const first = items.find((m) => m.kind === 'dbb') || items[0];
  if (first) await showMeasurement(first.id);
}

async function applyHome(unknown) {
  showMainView('home');
  await showHome(unknown);
}

// On a narrow screen the access-token form is folded behind the top bar's button (open while no
// token is set); on a wide one the button is not shown and the form always is.
function setTokenMenu(open) {
  $('.topbar').classList.toggle('menu-open', open);
  $('#menu-button').setAttribute('aria-expanded', String(open));
}

function onTokenSubmit(event) {
  event.preventDefault();
  const value = $('#token-input').value.trim();
  if (!value) {
    $('#token-input').focus();
    return;
  }
  setToken(value);
  $('#token-input').value = '';
  setTokenMenu(false);
  tokenChanged();
  start2();
}

function onTokenForget() {
  setToken('');
  setTokenMenu(true);
  tokenChanged();
  state.machines = [];
  state.machineId = null;
  state.list = { items: [], total: 0, offset: 0 };
  renderMachines();
  $('#measurements').replaceChildren();
  $('#measurements-machine').textContent = 'Select a machine.';
  $('#measurements-count').textContent = '';
  resetDetail();
  resetCalibration();
  resetJointHealth();
  resetAuditSummary();
  forgetRole();
  showAuthProblem(null);
}

// Everything that needs the token: machines, then the view the address names, streams.
async function start2() {
  await loadRole();
  await loadMachines();
  await applyRoute().catch((err) => handleAuth(err));
  refreshStreams();
}

function start() {
  takeTokenFromFragment();
  updateTokenStatus();
  $('#token-form').addEventListener('submit', onTokenSubmit);
  $('#token-forget').addEventListener('click', onTokenForget);
  $('#menu-button').addEventListener('click', () => setTokenMenu(!$('.topbar').classList.contains('menu-open')));
  setTokenMenu(!getToken());
  $('#machines-refresh').addEventListener('click', () => loadMachines());
  initUpload();
  initMeasurementList();
  initDetail();
  initCalibration();
  initServo();
  initFleet();
  initAudit();
  initTokens();
  initReports();
  window.addEventListener('hashchange', () => {
    if (takeTokenFromFragment()) {
      tokenChanged();
      start2();
      return;
    }
    applyRoute().catch((err) => handleAuth(err));
  });
  initStreams();
  Object.assign(shell, {
    getMachineId: () => state.machineId,
    getMachines: () => state.machines,
    getMeasurements: () => (state.dbbMachine === state.machineId ? state.dbb : []),
    handleAuth,
    // A machine the list does not know yet (uploaded meanwhile): the list is reloaded first.
    selectMachine: (id) => selectMachine(id),
    reloadMachines: () => loadMachines().then(() => loadJobHistory()),
  });
  initDiscovery();
  resetDetail();
  if (!getToken()) {
    showAuthProblem(null);
    $('#machines').replaceChildren(h('li', { class: 'empty' }, 'Waiting for an access token…'));
  } else {
    start2();
  }
  document.body.dataset.ready = 'true';
}

start();
