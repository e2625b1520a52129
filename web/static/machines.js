// The machines in the sidebar: list, selection, and what a selection loads (its measurement
// list, its DBB tests for the study forms, its job history).

import { api } from './api.js';
import { clearAuthProblem, handleAuth } from './auth.js';
import { $, errorBox, h, keepFocus } from './dom.js';
import { formatTimestamp } from './format.js';
import { loadJobHistory, resetCalibration, renderCalibrationChoices } from './calibration.js';
import { loadMeasurementPage, resetFilters } from './measurements.js';
import { resetDetail } from './detail.js';
import { loadJointHealth, resetJointHealth } from './servo.js';
import { machineHash, navigate, trendsHash } from './router.js';
import { state } from './state.js';
import { showAuditSummary } from './audit.js';
import { showTolerances } from './tolerances.js';
import { discoveryMachineChanged, discoveryMachinesChanged, leaveDiscovery, parseRoute } from './discovery.js';

export async function loadMachines() {
  const list = $('#machines');
  list.setAttribute('aria-busy', 'true');
  try {
    const data = await api.machines();
    clearAuthProblem();
    state.machines = data.machines || [];
    renderMachines();
    discoveryMachinesChanged();
  } catch (err) {
    if (!handleAuth(err)) list.replaceChildren(h('li', { class: 'empty' }, errorBox(err)));
    else list.replaceChildren(h('li', { class: 'empty' }, 'Waiting for an access token…'));
  } finally {
    list.removeAttribute('aria-busy');
  }
}

export function renderMachines() {
  const list = $('#machines');
  if (!state.machines.length) {
    list.replaceChildren(h('li', { class: 'empty' }, 'No machines yet. Upload a measurement file to start.'));
    return;
  }
  keepFocus(list, () =>
    list.replaceChildren(
      ...state.machines.map((m) =>
        h(
          'li',
          {},
          h(
            'button',
            {
              type: 'button',
              class: 'item',
              'data-testid': 'machine-item',
              'data-machine-id': m.machine_id,
              'data-focus-key': `machine:${m.machine_id}`,
              'aria-current': m.machine_id === state.machineId ? 'true' : 'false',
              onclick: () => onMachineClick(m.machine_id),
            },
            h('span', { class: 'item-title' }, m.machine_id),
            h(
              'span',
              { class: 'item-meta' },
              `${m.measurement_count ?? '?'} measurement${m.measurement_count === 1 ? '' : 's'}`,
              m.last_timestamp ? ` · last ${formatTimestamp(m.last_timestamp)}` : '',
            ),
          ),
        ),
      ),
    ),
  );
}

// A click on a machine: its address (#/machines/ID), or the discovery form for it when that
// form is shown.
function onMachineClick(machineId) {
  const route = parseRoute();
  if (route.view === 'discovery-new') {
    window.history.replaceState(null, '', `#/discoveries?machine=${encodeURIComponent(machineId)}`);
    selectMachine(machineId);
    return;
  }
  if (route.view === 'discovery') leaveDiscovery();
  navigate(machineHash(machineId));
}

// Makes machineId the selected machine: its list (first page, filters reset when the machine
// changes), its DBB tests and its jobs. Returns the first page's items.
export async function selectMachine(machineId) {
  const changed = machineId !== state.machineId;
  state.machineId = machineId;
  // What belonged to the previous machine goes at once, before anything is awaited.
  if (changed) {
    state.measurementId = null;
    resetFilters();
    resetDetail();
    resetCalibration();
    resetJointHealth();
  }
  $('#measurements-machine').textContent = `Machine ${machineId}`;
  $('#machine-trends-link').href = trendsHash(machineId);
  $('#machine-trends-link').hidden = false;
  if (!state.machines.some((m) => m.machine_id === machineId)) await loadMachines();
  renderMachines();
  const [items] = await Promise.all([loadMeasurementPage({ offset: 0 }), changed || state.dbbMachine !== machineId ? loadDbbTests(machineId) : null]);
  loadJobHistory();
  loadJointHealth(machineId);
  showAuditSummary(machineId);
  showTolerances(machineId);
  return items || [];
}

// The selected machine's list, DBB tests and jobs again (after uploads).
export async function refreshMachine() {
  if (!state.machineId) return;
  await Promise.all([loadMeasurementPage({ offset: 0 }), loadDbbTests(state.machineId), loadJointHealth(state.machineId)]);
}

// Every DBB test of the machine (oldest first) for the calibration and discovery forms, and
// whether the machine is a hexapod (a stored hexapod model, or tests with a tool length).
async function loadDbbTests(machineId) {
  try {
    const all = [];
    for (let offset = 0; ; offset += 1000) {
      const page = await api.measurements(machineId, { kind: 'dbb', limit: 1000, offset, order: 'oldest' });
      all.push(...(page.items || []));
      if (all.length >= (page.total ?? 0) || !(page.items || []).length || all.length >= 5000) break;
    }
    if (state.machineId !== machineId) return;
    state.dbb = all;
    state.dbbMachine = machineId;
    state.hexapod = await isHexapod(machineId, all);
    if (state.machineId !== machineId) return;
    renderCalibrationChoices();
    discoveryMachineChanged();
  } catch (err) {
    handleAuth(err);
  }
}

async function isHexapod(machineId, dbb) {
  const summary = state.machines.find((m) => m.machine_id === machineId);
  if (summary && summary.model_versions > 0) {
    try {
      const doc = await api.machineDefinition(machineId);
      if (doc && typeof doc.kind === 'string') return doc.kind === 'hexapod';
    } catch {
      // fall back to the tests
    }
  }
  if (!dbb.length) return false;
  try {
    const m = await api.measurement(dbb[dbb.length - 1].id);
    return Boolean(m && m.metadata && m.metadata.tool_length_mm !== undefined);
  } catch {
    return false;
  }
}
