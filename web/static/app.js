// kinemetric dashboard: machines → measurements (paged, filtered) → DBB polar plot, figures and
// diagnosis of the pair the server analyses; form and tracker plots; calibration jobs with the
// server's verdict; uploads; streams. Each view has its address (router.js); the model-gap
// discovery page (#/discoveries…) is discovery.js.
// Plain ES modules, no build step, nothing loaded from outside the server. One module a view:
// machines.js, measurements.js, detail.js (figures.js, diagnosis.js, formplots.js),
// calibration.js, upload.js, streams.js, discovery.js; DOM helpers in dom.js.

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
import { forgetRole, loadRole } from './roles.js';
import { initServo, resetJointHealth } from './servo.js';
import { initStreams, refreshStreams } from './streams.js';
import { initUpload } from './upload.js';

// Which main view is shown: the measurement view (#detail), a calibration job (#job-view) or the
// discovery page (#discovery, shown by discovery.js).
function showMainView(which) {
  $('#detail').hidden = which !== 'detail';
  $('#job-view').hidden = which !== 'job';
  $('#fleet-view').hidden = which !== 'fleet';
  $('#trends-view').hidden = which !== 'trends';
  if (which !== 'discovery') $('#discovery').hidden = true;
}

// Shows what the address names; called at start and on every hashchange.
let routeSeq = 0; // a newer address overrides what an older one was still loading

async function applyRoute() {
  const seq = ++routeSeq;
  const route = parseAppRoute();
  document.body.dataset.route = route.view;
  if (route.view === 'discovery') {
    $('#job-view').hidden = true;
    $('#fleet-view').hidden = true;
    $('#trends-view').hidden = true;
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
  showMainView('detail');
  if (route.view === 'measurement') {
    await showMeasurement(route.id);
    return;
  }
  let machineId = route.view === 'machine' ? route.machineId : state.machineId;
  if (!machineId && state.machines.length === 1) machineId = state.machines[0].machine_id;
  if (!machineId) return;
  const items = await selectMachine(machineId);
  if (seq !== routeSeq) return;
  // The machine's newest DBB test on this page (else its newest measurement).
  if (state.measurementId && items.some((m) => m.id === state.measurementId)) return;
  const first = items.find((m) => m.kind === 'dbb') || items[0];
  if (first) await showMeasurement(first.id);
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
  tokenChanged();
  start2();
}

function onTokenForget() {
  setToken('');
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
  $('#machines-refresh').addEventListener('click', () => loadMachines());
  initUpload();
  initMeasurementList();
  initDetail();
  initCalibration();
  initServo();
  initFleet();
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
