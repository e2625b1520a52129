// kinemetric dashboard: machines → measurements → DBB polar plot, figures and diagnosis;
// straightness / parallelism profiles and flatness maps with their figures; plus upload. The
// model-gap discovery page (#/discoveries…) is discovery.js.
// Plain ES module, no build step, nothing loaded from outside the server.

import { api, ApiError, getToken, setToken, takeTokenFromFragment } from './api.js';
import { renderColourMap, renderContributionChart, renderHarmonicsChart, renderProfilePlot } from './charts.js';
import {
  displayUnit,
  effectWords,
  formatDirection,
  formatMode,
  formatNumber,
  formatTimestamp,
  fullLabelOf,
  labelOf,
  unitOf,
} from './format.js';
import { renderPolarPlot } from './polar.js';
import { errorBox, h, problemContent, setMessage } from './dom.js';
import { renderTrackerVectorPlot } from './tracker.js';
import { renderComponentCharts } from './components.js';
import { initStreams, refreshStreams } from './streams.js';
import {
  applyRoute,
  discoveryMachineChanged,
  discoveryMachinesChanged,
  initDiscovery,
  leaveDiscovery,
  parseRoute,
} from './discovery.js';

const $ = (sel) => document.querySelector(sel);

const state = {
  machines: [],
  machineId: null,
  measurements: [],
  measurementId: null,
  selectSeq: 0, // guards against out-of-order responses when clicking quickly
  pngUrl: null, // object URL of the PNG plot shown in the dialog
  calibChecked: new Set(), // DBB measurement ids ticked in the calibration panel
  calibSeq: 0, // a new job or another machine stops the polling of the previous job
};

const JOB_POLL_MS = 500;

const FORM_KINDS = ['straightness', 'parallelism', 'flatness'];
// Kinds drawn wide (plot above the figures); they need the stored samples as well.
const WIDE_KINDS = [...FORM_KINDS, 'tracker'];

// ---------------------------------------------------------------- token / auth

function updateTokenStatus() {
  const has = Boolean(getToken());
  $('#token-status').textContent = has ? 'Access token set' : 'No access token';
  $('#token-status').classList.toggle('missing', !has);
  $('#token-forget').disabled = !has;
}

function showAuthProblem(err) {
  const banner = $('#auth-message');
  const reason = getToken()
    ? 'The server did not accept the access token.'
    : 'An access token is needed to use the dashboard.';
  setMessage(
    banner,
    'error',
    h('strong', {}, 'Access token required (401). '),
    `${reason} Enter your token in the “Access token” box at the top right and press “Use token”.`,
    err && err.detail ? h('span', { class: 'problem-detail' }, `Server said: ${err.detail}`) : '',
  );
  $('#token-input').focus();
}

function clearAuthProblem() {
  setMessage($('#auth-message'), null);
}

// Returns true if the error was an auth problem (and has been shown).
function handleAuth(err) {
  if (err instanceof ApiError && err.status === 401) {
    showAuthProblem(err);
    return true;
  }
  return false;
}

// ---------------------------------------------------------------- machines

async function loadMachines({ select, selectMeasurement } = {}) {
  const list = $('#machines');
  list.setAttribute('aria-busy', 'true');
  try {
    const data = await api.machines();
    clearAuthProblem();
    state.machines = data.machines || [];
    renderMachines();
    discoveryMachinesChanged();
    const target = select ?? state.machineId;
    if (target && state.machines.some((m) => m.machine_id === target)) {
      await selectMachine(target, { selectMeasurement });
    } else if (!state.machineId && state.machines.length === 1) {
      await selectMachine(state.machines[0].machine_id);
    }
  } catch (err) {
    if (!handleAuth(err)) list.replaceChildren(h('li', { class: 'empty' }, errorBox(err)));
    else list.replaceChildren(h('li', { class: 'empty' }, 'Waiting for an access token…'));
  } finally {
    list.removeAttribute('aria-busy');
  }
}

function renderMachines() {
  const list = $('#machines');
  if (!state.machines.length) {
    list.replaceChildren(h('li', { class: 'empty' }, 'No machines yet. Upload a measurement file to start.'));
    return;
  }
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
  );
}

// A click on a machine: the measurement view of that machine, or the discovery form for it
// when that form is shown.
function onMachineClick(machineId) {
  const route = parseRoute();
  if (route.view === 'discovery') leaveDiscovery();
  else if (route.view === 'discovery-new') {
    window.history.replaceState(null, '', `#/discoveries?machine=${encodeURIComponent(machineId)}`);
  }
  selectMachine(machineId);
}

// ---------------------------------------------------------------- measurements

async function selectMachine(machineId, { selectMeasurement } = {}) {
  const changed = machineId !== state.machineId;
  state.machineId = machineId;
  renderMachines();
  $('#measurements-machine').textContent = `Machine ${machineId}`;
  const list = $('#measurements');
  list.setAttribute('aria-busy', 'true');
  if (changed) {
    state.measurementId = null;
    resetDetail();
    resetCalibration();
  }
  try {
    const data = await api.measurements(machineId);
    if (state.machineId !== machineId) return; // another machine was clicked meanwhile
    state.measurements = data.items || [];
    const total = data.total ?? state.measurements.length;
    $('#measurements-count').textContent =
      total > state.measurements.length ? `showing ${state.measurements.length} of ${total}` : `${total}`;
    renderMeasurements();
    renderCalibrationChoices();
    discoveryMachineChanged();
    const target = selectMeasurement ?? state.measurementId;
    // Keep the selection; otherwise show the newest DBB test (else the newest measurement).
    const item =
      state.measurements.find((m) => m.id === target) ||
      state.measurements.filter((m) => m.kind === 'dbb').sort((x, y) => y.id - x.id)[0] ||
      [...state.measurements].sort((x, y) => y.id - x.id)[0];
    if (item) await selectMeasurementItem(item);
  } catch (err) {
    if (!handleAuth(err)) list.replaceChildren(h('li', { class: 'empty' }, errorBox(err)));
  } finally {
    list.removeAttribute('aria-busy');
  }
}

function renderMeasurements() {
  const list = $('#measurements');
  if (!state.measurements.length) {
    list.replaceChildren(h('li', { class: 'empty' }, 'No measurements for this machine.'));
    return;
  }
  list.replaceChildren(
    ...state.measurements.map((m) =>
      h(
        'li',
        {},
        h(
          'button',
          {
            type: 'button',
            class: 'item',
            'data-testid': 'measurement-item',
            'data-id': m.id,
            'data-kind': m.kind,
            'data-test-id': m.test_id ?? '',
            'data-direction': m.direction ?? '',
            'aria-current': m.id === state.measurementId ? 'true' : 'false',
            onclick: () => {
              leaveDiscovery();
              selectMeasurementItem(m);
            },
          },
          h(
            'span',
            { class: 'item-title' },
            m.test_id || m.filename || `#${m.id}`,
            m.direction ? h('span', { class: `badge dir-${m.direction}` }, formatDirection(m.direction)) : '',
          ),
          h(
            'span',
            { class: 'item-meta' },
            [String(m.kind || '').toUpperCase(), formatTimestamp(m.timestamp || m.uploaded_at), m.filename, `#${m.id}`]
              .filter(Boolean)
              .join(' · '),
          ),
        ),
      ),
    ),
  );
}

// The other direction of the same DBB test on the same machine (newest upload wins).
function partnerOf(item) {
  if (item.kind !== 'dbb' || !item.test_id || !item.direction) return null;
  const other = item.direction === 'ccw' ? 'cw' : item.direction === 'cw' ? 'ccw' : null;
  if (!other) return null;
  const candidates = state.measurements.filter(
    (m) => m.kind === 'dbb' && m.test_id === item.test_id && m.direction === other,
  );
  candidates.sort((a, b) => b.id - a.id);
  return candidates[0] || null;
}

function resetDetail() {
  $('#detail-heading').textContent = 'Polar plot and figures';
  $('#plot-note').textContent = '';
  $('#polar-plot').replaceChildren(
    h('p', { class: 'placeholder' }, 'Select a measurement to see its plot.'),
  );
  $('#figures').replaceChildren(h('p', { class: 'placeholder' }, 'Figures appear here.'));
  $('#figures-extra').replaceChildren();
  resetAnalysis();
  setDetailLayout(null);
}

function resetAnalysis() {
  $('#analysis').hidden = true;
  $('#diagnosis-table-box').replaceChildren();
  $('#contribution-chart').replaceChildren();
  $('#harmonics-chart').replaceChildren();
  $('#diagnosis-source').textContent = '';
  $('#not-identifiable').hidden = true;
  $('#not-identifiable').replaceChildren();
  $('#plot-png-button').hidden = true;
}

// DBB: polar plot beside the figures; form measurements: the wide plot above the figures.
function setDetailLayout(kind) {
  const wide = WIDE_KINDS.includes(kind);
  $('#detail-body').classList.toggle('wide', wide);
  $('#polar-plot').classList.toggle('polar-figure', !wide);
}

function detailHeading(item) {
  const machine = item.machine_id || state.machineId;
  if (item.kind === 'dbb') return `${item.test_id || item.filename || `Measurement #${item.id}`} — ${machine}`;
  const kind = String(item.kind || 'measurement');
  const what = `${kind.charAt(0).toUpperCase()}${kind.slice(1)}`;
  return `${what} ${item.test_id ? `${item.test_id} ` : ''}· ${item.filename || `#${item.id}`} — ${machine}`;
}

async function selectMeasurementItem(item) {
  const seq = ++state.selectSeq;
  state.measurementId = item.id;
  renderMeasurements();
  const partner = partnerOf(item);
  const items = [item, partner].filter(Boolean);
  // Fixed order: CCW first, then CW, so colours and columns do not swap between clicks.
  items.sort((a, b) => (a.direction === 'ccw' ? 0 : 1) - (b.direction === 'ccw' ? 0 : 1));

  $('#detail-heading').textContent = detailHeading(item);
  $('#polar-plot').setAttribute('aria-busy', 'true');
  $('#figures').setAttribute('aria-busy', 'true');
  try {
    const wantTrace = item.kind === 'dbb';
    const wantSamples = WIDE_KINDS.includes(item.kind);
    // The pair analysis (joint CW + CCW diagnosis, hysteresis) only when a partner is listed.
    const pairPromise = wantTrace && partner ? api.pair(item.id) : Promise.resolve(null);
    const [settled, pairSettled] = await Promise.all([
      Promise.allSettled(
        items.map(async (m) => {
          const [results, trace, measurement] = await Promise.all([
            api.results(m.id),
            wantTrace ? api.trace(m.id) : Promise.resolve(null),
            wantSamples ? api.measurement(m.id) : Promise.resolve(null),
          ]);
          return { item: m, results, trace, measurement };
        }),
      ),
      pairPromise.then(
        (value) => ({ status: 'fulfilled', value }),
        (reason) => ({ status: 'rejected', reason }),
      ),
    ]);
    if (seq !== state.selectSeq) return;
    // The selected measurement must evaluate; a partner that does not is reported and left out.
    const own = settled[items.indexOf(item)];
    if (own.status === 'rejected') throw own.reason;
    const fetched = settled.filter((r) => r.status === 'fulfilled').map((r) => r.value);
    const pair = pairSettled.status === 'fulfilled' ? pairSettled.value : null;
    if (pairSettled.status === 'rejected' && handleAuth(pairSettled.reason)) return;
    setDetailLayout(item.kind);
    renderPlot(item, fetched);
    renderFigures(fetched, { kind: item.kind, pair });
    renderAnalysis(item, fetched, pair, pairSettled.status === 'rejected' ? pairSettled.reason : null);
    const failedPartner = settled.find((r) => r.status === 'rejected');
    if (failedPartner) {
      if (handleAuth(failedPartner.reason)) return;
      $('#plot-note').textContent =
        `The ${formatDirection(partner.direction)} file of this test (#${partner.id}) could not be evaluated: ` +
        `${failedPartner.reason.detail || failedPartner.reason.message}`;
    }
  } catch (err) {
    if (seq !== state.selectSeq) return;
    if (!handleAuth(err)) {
      $('#polar-plot').replaceChildren(errorBox(err));
      $('#figures').replaceChildren();
      $('#figures-extra').replaceChildren();
      resetAnalysis();
    }
  } finally {
    if (seq === state.selectSeq) {
      $('#polar-plot').removeAttribute('aria-busy');
      $('#figures').removeAttribute('aria-busy');
    }
  }
}

// ---------------------------------------------------------------- plot

function renderPlot(item, fetched) {
  const container = $('#polar-plot');
  const note = $('#plot-note');
  if (FORM_KINDS.includes(item.kind)) {
    renderFormPlot(item, fetched.find((f) => f.item.id === item.id));
    return;
  }
  if (item.kind === 'tracker') {
    renderTrackerPlot(item, fetched.find((f) => f.item.id === item.id));
    return;
  }
  if (item.kind !== 'dbb') {
    container.replaceChildren(
      h('p', { class: 'placeholder' }, `No plot for ${String(item.kind).toUpperCase()} measurements yet.`),
    );
    note.textContent = '';
    return;
  }
  const traces = fetched
    .filter((f) => f.trace)
    .map((f) => ({ ...f.trace, direction: f.trace.direction || f.item.direction, test_id: f.item.test_id }));
  const { svg } = renderPolarPlot(traces, { title: `DBB ${item.test_id || ''}`.trim() });
  container.replaceChildren(svg);
  const dirs = traces.map((t) => t.direction);
  if (dirs.length === 1) {
    const other = dirs[0] === 'ccw' ? 'CW' : 'CCW';
    note.textContent = `Only ${formatDirection(dirs[0])} is stored for this test; upload the ${other} file with the same test_id to overlay both directions.`;
  } else {
    note.textContent = 'Radial error about the least-squares circle, magnified around the nominal circle (thick grey).';
  }
}

// ---------------------------------------------------------------- figures

const LEAD_ROWS = ['test_id', 'direction', 'mode', 'centre_offset_x_um', 'centre_offset_y_um', 'average_radial_error_um', 'circularity_um'];

// The headline figures of each kind, in this order, before everything else.
const KIND_ROWS = {
  dbb: [
    ...LEAD_ROWS,
    'min_zone_circularity_um',
    'iso230_4.circular_deviation_um',
    'iso230_4.radial_deviation_max_um',
    'iso230_4.radial_deviation_min_um',
  ],
  straightness: [
    'straightness_lsq_um',
    'straightness_min_zone_um',
    'straightness_end_point_um',
    'slope_um_per_m',
    'length_mm',
    'points',
  ],
  parallelism: ['parallelism_um', 'slope_um_per_m', 'straightness_lsq_um', 'length_mm', 'points'],
  tracker: ['residual_rms_um', 'condition_number', 'rejected_readings_count', 'sigma_um', 'readings_used', 'unknowns', 'iterations'],
  flatness: [
    'flatness_lsq_um',
    'flatness_min_zone_um',
    'range_um',
    'plane.slope_x_um_per_m',
    'plane.slope_y_um_per_m',
    'plane.offset_um',
    'points',
  ],
};

const CAPTIONS = {
  dbb: 'DBB figures',
  straightness: 'Straightness figures',
  parallelism: 'Parallelism figures',
  flatness: 'Flatness figures',
  tracker: 'Laser-tracker self-calibration',
};

// Arrays drawn as charts / tables of their own rather than as rows of the figures table.
const OWN_VIEWS = new Set(['harmonics', 'diagnosis', 'not_identifiable', 'periodic', 'references', 'measurement', 'decomposition', 'transform', 'point_ids']);

// Flattens one results object into {key: value} rows; arrays of objects are returned apart.
function flattenResults(results) {
  const flat = {};
  const tables = {};
  for (const [key, value] of Object.entries(results || {})) {
    if (OWN_VIEWS.has(key)) continue;
    if (key === 'rejected_readings' && Array.isArray(value)) {
      flat.rejected_readings_count = value.length; // the list itself is a table below
      if (value.length && value.every((v) => v && typeof v === 'object')) tables[key] = value;
      continue;
    }
    if (key === 'centre_offset_um' && Array.isArray(value)) {
      flat.centre_offset_x_um = value[0];
      flat.centre_offset_y_um = value[1];
    } else if (typeof value === 'number' || typeof value === 'string' || typeof value === 'boolean') {
      flat[key] = value;
    } else if (Array.isArray(value)) {
      if (!value.length) continue;
      if (value.every((v) => typeof v === 'number')) flat[key] = value;
      else if (value.every((v) => v && typeof v === 'object' && !Array.isArray(v))) tables[key] = value;
    } else if (value && typeof value === 'object') {
      for (const [k2, v2] of Object.entries(value)) {
        if (typeof v2 === 'number') flat[`${key}.${k2}`] = v2;
      }
    }
  }
  return { flat, tables };
}

function cellText(key, value) {
  if (value === undefined || value === null) return '—';
  if (key === 'direction') return formatDirection(value);
  if (key === 'mode') return formatMode(value);
  if (typeof value === 'number') return formatNumber(value, key.split('.').pop());
  if (Array.isArray(value)) {
    const leaf = key.split('.').pop();
    const sep = leaf.endsWith('_deg') && value.length === 2 ? ' to ' : ', ';
    return value.map((v) => formatNumber(v, leaf)).join(sep);
  }
  return String(value).replace(/_/g, ' ');
}

function rowLabel(key) {
  const full = fullLabelOf(key);
  if (full) return full;
  const [parent, leaf] = key.includes('.') ? key.split('.', 2) : [null, key];
  const label = labelOf(leaf);
  if (!parent || /ISO 230-4/.test(label)) return label;
  return `${labelOf(parent)}: ${label.charAt(0).toLowerCase()}${label.slice(1)}`;
}

function renderFigures(fetched, { kind = 'dbb', pair = null } = {}) {
  const columns = fetched.map((f) => ({ item: f.item, ...flattenResults(f.results) }));
  const lead = KIND_ROWS[kind] || [];
  // Row order: the lead rows, then every other numeric key, then other values (e.g. versions).
  const seen = new Set();
  const keys = [];
  const push = (k) => {
    if (!seen.has(k)) {
      seen.add(k);
      keys.push(k);
    }
  };
  lead.forEach(push);
  const rest = [];
  seen.add('machine_id'); // already in the heading
  for (const c of columns) for (const k of Object.keys(c.flat)) if (!seen.has(k) && !rest.includes(k)) rest.push(k);
  const isNumeric = (k) => columns.some((c) => typeof c.flat[k] === 'number' || Array.isArray(c.flat[k]));
  rest.filter(isNumeric).forEach(push);
  rest.filter((k) => !isNumeric(k)).forEach(push);

  const thead = h(
    'thead',
    {},
    h(
      'tr',
      {},
      h('th', { scope: 'col' }, 'Quantity'),
      h('th', { scope: 'col', class: 'unit' }, 'Unit'),
      ...columns.map((c) =>
        h(
          'th',
          { scope: 'col', class: `num dir-${c.item.direction || 'none'}`, 'data-direction': c.item.direction || '' },
          c.item.direction && kind === 'dbb' ? formatDirection(c.item.direction) : 'Value',
          h('span', { class: 'col-id' }, ` #${c.item.id}`),
        ),
      ),
    ),
  );
  const tbody = h('tbody');
  const alwaysShown = kind === 'dbb' ? LEAD_ROWS.slice(0, 2) : [];
  for (const key of keys) {
    if (columns.every((c) => c.flat[key] === undefined) && !alwaysShown.includes(key)) continue;
    const leaf = key.split('.').pop();
    const numeric = isNumeric(key);
    const { unit } = unitOf(leaf);
    tbody.append(
      h(
        'tr',
        { 'data-key': key, class: lead.includes(key) ? 'lead' : '' },
        h('th', { scope: 'row' }, rowLabel(key)),
        h('td', { class: 'unit' }, numeric ? unit : ''),
        ...columns.map((c) =>
          h(
            'td',
            { class: numeric ? 'num' : 'text', 'data-key': key, 'data-direction': c.item.direction || '', 'data-id': c.item.id },
            cellText(key, key === 'test_id' ? c.flat[key] ?? c.item.test_id : key === 'direction' ? c.flat[key] ?? c.item.direction : c.flat[key]),
          ),
        ),
      ),
    );
  }
  // CW + CCW figures of the pair (ISO 230-4): one value for both directions.
  if (pair && pair.pair) {
    const rows = ['circular_hysteresis_um', 'bidirectional_circular_deviation_um'].filter((k) => typeof pair.pair[k] === 'number');
    const firstLeadRow = [...tbody.children].findIndex((tr) => !tr.classList.contains('lead') && !KIND_ROWS.dbb.includes(tr.dataset.key));
    const anchor = firstLeadRow >= 0 ? tbody.children[firstLeadRow] : null;
    for (const k of rows) {
      tbody.insertBefore(
        h(
          'tr',
          { 'data-key': `pair.${k}`, class: 'lead pair-row' },
          h('th', { scope: 'row' }, labelOf(k)),
          h('td', { class: 'unit' }, unitOf(k).unit),
          h('td', { class: 'num', colspan: columns.length, 'data-key': `pair.${k}`, 'data-testid': `pair-${k}` }, formatNumber(pair.pair[k], k)),
        ),
        anchor,
      );
    }
  }
  const table = h('table', { class: 'figures', 'data-testid': 'figures-table', 'data-kind': kind }, h('caption', {}, CAPTIONS[kind] || 'Figures'), thead, tbody);
  $('#figures').replaceChildren(table);
  renderExtraTables(columns, fetched, kind);
}

// The periodic components of a straightness profile as a visible table; any other arrays of
// objects as small tables, folded by default.
function renderExtraTables(columns, fetched, kind) {
  const box = $('#figures-extra');
  const blocks = [];
  if (kind === 'straightness') {
    const own = fetched[0]?.results || {};
    const periodic = Array.isArray(own.periodic) ? own.periodic : [];
    blocks.push(periodicTable(periodic));
  }
  if (kind === 'tracker') blocks.push(decompositionTable(fetched[0]?.results?.decomposition));
  const names = [...new Set(columns.flatMap((c) => Object.keys(c.tables)))];
  for (const name of names) {
    for (const c of columns) {
      const rows = c.tables[name];
      if (!rows || !rows.length) continue;
      const keys = [...new Set(rows.flatMap((r) => Object.keys(r)))];
      const numericKey = (k) => rows.some((r) => typeof r[k] === 'number');
      blocks.push(
        h(
          'details',
          { 'data-table': name, 'data-direction': c.item.direction || '' },
          h('summary', {}, `${labelOf(name)} — ${formatDirection(c.item.direction)} (${rows.length})`),
          h(
            'table',
            { class: 'figures small' },
            h('thead', {}, h('tr', {}, ...keys.map((k) => h('th', { scope: 'col', class: numericKey(k) ? 'num' : '' }, labelWithUnit(k))))),
            h(
              'tbody',
              {},
              ...rows.map((r) =>
                h('tr', {}, ...keys.map((k) => h('td', { class: numericKey(k) ? 'num' : 'text' }, cellText(k, r[k])))),
              ),
            ),
          ),
        ),
      );
    }
  }
  box.replaceChildren(...blocks);
}

function periodicTable(periodic) {
  const caption = h('caption', {}, 'Periodic components (in the least-squares residual)');
  if (!periodic.length) {
    return h(
      'table',
      { class: 'figures small periodic', 'data-testid': 'periodic-table' },
      caption,
      h('tbody', {}, h('tr', {}, h('td', { class: 'text-left' }, 'No significant periodic component found.'))),
    );
  }
  const cols = [
    ['period_mm', 'Period', 'mm', (v) => formatNumber(v, '_um')],
    ['amplitude_um', 'Amplitude', 'µm', (v) => formatNumber(v, '_um')],
    ['peak_to_valley_um', 'Peak to valley', 'µm', (v) => formatNumber(v, '_um')],
    ['phase_deg', 'Phase', '°', (v) => formatNumber(v, '_deg')],
  ];
  return h(
    'table',
    { class: 'figures small periodic', 'data-testid': 'periodic-table' },
    caption,
    h('thead', {}, h('tr', {}, ...cols.map(([, label, unit]) => h('th', { scope: 'col', class: 'num' }, unit ? `${label} (${unit})` : label)))),
    h(
      'tbody',
      {},
      ...periodic.map((p, i) =>
        h(
          'tr',
          { 'data-index': i },
          ...cols.map(([key, , , fmt]) => {
            const v = key === 'peak_to_valley_um' ? 2 * p.amplitude_um : p[key];
            return h('td', { class: 'num', 'data-key': key }, fmt(v));
          }),
        ),
      ),
    ),
  );
}

// Tracker decomposition (scale per axis in ppm, squareness per plane in µm/m, each ± σ).
function decompositionTable(dec) {
  const caption = h('caption', {}, 'Error decomposition (machine axes)');
  if (!dec || typeof dec !== 'object') {
    return h(
      'table',
      { class: 'figures small decomposition', 'data-testid': 'decomposition-table' },
      caption,
      h('tbody', {}, h('tr', {}, h('td', { class: 'text-left' }, 'No decomposition in the results.'))),
    );
  }
  const rows = [
    ...['x', 'y', 'z'].map((a) => ({ key: `scale_ppm.${a}`, label: `Scale ${a.toUpperCase()}`, unit: 'ppm', v: dec.scale_ppm?.[a], s: dec.scale_sigma_ppm?.[a] })),
    ...['xy', 'yz', 'zx'].map((p) => ({
      key: `squareness_um_per_m.${p}`,
      label: `Squareness ${p.toUpperCase()}`,
      unit: 'µm/m',
      v: dec.squareness_um_per_m?.[p],
      s: dec.squareness_sigma_um_per_m?.[p],
    })),
  ];
  const f3 = (v) => formatNumber(v, '_um');
  const table = h(
    'table',
    { class: 'figures small decomposition', 'data-testid': 'decomposition-table' },
    caption,
    h(
      'thead',
      {},
      h(
        'tr',
        {},
        h('th', { scope: 'col' }, 'Term'),
        h('th', { scope: 'col', class: 'num' }, 'Value'),
        h('th', { scope: 'col', class: 'num', title: 'standard uncertainty' }, '± σ'),
        h('th', { scope: 'col', class: 'unit' }, 'Unit'),
      ),
    ),
    h(
      'tbody',
      {},
      ...rows.map((r) =>
        h(
          'tr',
          { 'data-key': r.key },
          h('th', { scope: 'row' }, r.label),
          h('td', { class: 'num', 'data-key': 'value' }, f3(r.v)),
          h('td', { class: 'num', 'data-key': 'sigma' }, `± ${f3(r.s)}`),
          h('td', { class: 'unit' }, r.unit),
        ),
      ),
    ),
  );
  const fixed = Array.isArray(dec.fixed) ? dec.fixed : [];
  if (!fixed.length) return table;
  return h(
    'div',
    {},
    table,
    h(
      'details',
      { 'data-table': 'decomposition-fixed' },
      h('summary', {}, `Terms not identified (${fixed.length})`),
      h('ul', { class: 'fixed-terms' }, ...fixed.map((t) => h('li', {}, String(t)))),
    ),
  );
}

function renderTrackerPlot(item, f) {
  const container = $('#polar-plot');
  const note = $('#plot-note');
  const r = f?.results || {};
  const s = f?.measurement?.samples || {};
  const xs = s.x_mm || [];
  const errors = Array.isArray(r.volumetric_error_um) ? r.volumetric_error_um : [];
  if (!xs.length || xs.length !== errors.length) {
    container.replaceChildren(h('p', { class: 'placeholder' }, 'No volumetric error map for this measurement.'));
    note.textContent = '';
    return;
  }
  const points = xs.map((x, i) => [x, s.y_mm[i], s.z_mm[i]]);
  const { svg } = renderTrackerVectorPlot(points, errors, { title: `Volumetric error of ${item.machine_id || ''}`.trim() });
  container.replaceChildren(svg);
  if (r.decomposition && typeof r.decomposition === 'object') container.append(renderComponentCharts(r.decomposition));
  const dropped = errors.filter((e) => !e).length;
  note.textContent =
    'Volumetric error at each commanded point (arrow, magnified) after the best-fit placement of the machine frame' +
    (dropped ? `; ${dropped} point${dropped === 1 ? '' : 's'} dropped (hollow).` : '.');
}

function labelWithUnit(key) {
  const { unit } = unitOf(key);
  return unit ? `${labelOf(key)} (${unit})` : labelOf(key);
}

// ---------------------------------------------------------------- DBB diagnosis and harmonics

function valueText(v) {
  if (Array.isArray(v)) return v.map((x) => formatNumber(x, '_um')).join(', ');
  return formatNumber(v, '_um');
}

function shapeText(d) {
  const parts = [];
  if (typeof d.period_mm === 'number') parts.push(`period ${formatNumber(d.period_mm, '_um')} mm`);
  if (typeof d.width_deg === 'number') parts.push(`width ${formatNumber(d.width_deg, '_deg')}°`);
  if (typeof d.period_deg === 'number') parts.push(`period ${formatNumber(d.period_deg, '_deg')}°`);
  return parts.join(', ');
}

function renderAnalysis(item, fetched, pair, pairError) {
  resetAnalysis();
  if (item.kind !== 'dbb') return;
  $('#analysis').hidden = false;
  $('#plot-png-button').hidden = false;
  const own = fetched.find((f) => f.item.id === item.id);
  const results = own?.results || {};
  const joint = pair && Array.isArray(pair.joint_diagnosis);
  const diagnosis = [...(joint ? pair.joint_diagnosis : results.diagnosis || [])];
  diagnosis.sort((a, b) => (b.contribution_pct || 0) - (a.contribution_pct || 0));
  const dir = formatDirection(item.direction);
  const source = $('#diagnosis-source');
  source.dataset.source = joint ? 'pair' : 'single';
  if (joint) {
    const other = formatDirection(item.direction === 'ccw' ? 'cw' : 'ccw');
    source.textContent =
      `Joint diagnosis of CW and CCW fitted together (with ${other} #${pair.partner_id}) — the better one, ` +
      `because each effect shows differently in the two directions. Contributions are to the ${dir} circularity.`;
  } else {
    source.textContent =
      `Diagnosis of the ${dir} test alone (#${item.id}). ` +
      (pairError
        ? `The joint CW + CCW diagnosis could not be fetched: ${pairError.detail || pairError.message}`
        : 'Upload the opposite direction with the same test_id for the better, joint CW + CCW diagnosis.');
  }

  if (!diagnosis.length) {
    $('#diagnosis-table-box').replaceChildren(
      h('p', { class: 'placeholder', 'data-testid': 'diagnosis-empty' }, 'No significant error found: the circularity is within the noise.'),
    );
  } else {
    const tbody = h(
      'tbody',
      {},
      ...diagnosis.map((d, i) =>
        h(
          'tr',
          { 'data-effect': d.effect, 'data-testid': 'diagnosis-row' },
          h('td', { class: 'num rank' }, String(i + 1)),
          h(
            'th',
            { scope: 'row' },
            h('span', { class: 'effect-words' }, effectWords(d.effect)),
            h('span', { class: 'effect-name' }, d.effect),
            shapeText(d) ? h('span', { class: 'effect-shape' }, shapeText(d)) : '',
          ),
          h('td', { class: 'num', 'data-key': 'value' }, valueText(d.value)),
          h('td', { class: 'unit' }, displayUnit(d.unit)),
          h('td', { class: 'num', 'data-key': 'uncertainty' }, `± ${valueText(d.uncertainty)}`),
          h('td', { class: 'num', 'data-key': 'contribution_pct' }, formatNumber(d.contribution_pct, '_pct')),
        ),
      ),
    );
    $('#diagnosis-table-box').replaceChildren(
      h(
        'table',
        { class: 'figures diagnosis', 'data-testid': 'diagnosis-table', 'data-source': joint ? 'pair' : 'single' },
        h(
          'thead',
          {},
          h(
            'tr',
            {},
            h('th', { scope: 'col', class: 'num' }, '#'),
            h('th', { scope: 'col' }, 'Effect'),
            h('th', { scope: 'col', class: 'num' }, 'Value'),
            h('th', { scope: 'col', class: 'unit' }, 'Unit'),
            h('th', { scope: 'col', class: 'num', title: 'standard uncertainty' }, 'Uncertainty'),
            h('th', { scope: 'col', class: 'num' }, 'Share %'),
          ),
        ),
        tbody,
      ),
    );
    const total = diagnosis.reduce((s, d) => s + (Number(d.contribution_pct) || 0), 0);
    const rest = Math.max(0, 100 - total);
    $('#contribution-chart').replaceChildren(
      renderContributionChart(diagnosis, { unexplained: rest, title: `Share of the ${dir} circularity` }),
      h('figcaption', {}, `Share of the ${dir} circularity (peak to valley) explained by each effect.`),
    );
  }
  const ni = Array.isArray(results.not_identifiable) ? results.not_identifiable : [];
  if (ni.length) {
    const box = $('#not-identifiable');
    box.hidden = false;
    box.replaceChildren(
      h('strong', {}, joint ? `Not identifiable from the ${dir} test alone: ` : 'Not identifiable from this data: '),
      ni.map((s) => String(s).replace(/^([a-z_]+)/, (m) => `${effectWords(m)} (${m})`)).join('; '),
      '.',
    );
  }
  const series = fetched
    .filter((f) => Array.isArray(f.results?.harmonics) && f.results.harmonics.length)
    .map((f) => ({ direction: f.item.direction, harmonics: f.results.harmonics }));
  if (series.length) $('#harmonics-chart').replaceChildren(renderHarmonicsChart(series));
  else $('#harmonics-chart').replaceChildren(h('p', { class: 'placeholder' }, 'No harmonics in the results.'));
}

// ---------------------------------------------------------------- form plots

function sampleColumns(f) {
  const s = f?.measurement?.samples || {};
  return s;
}

function renderFormPlot(item, f) {
  const container = $('#polar-plot');
  const note = $('#plot-note');
  const r = f?.results || {};
  const s = sampleColumns(f);
  const meta = f?.measurement?.metadata || {};
  const n = (s.x_mm || s.position_mm || []).length;
  if (n < 2 || !Object.keys(r).length) {
    container.replaceChildren(h('p', { class: 'placeholder' }, 'No samples to plot for this measurement.'));
    note.textContent = '';
    return;
  }
  if (item.kind === 'flatness') {
    const x = s.x_mm || [];
    const y = s.y_mm || [];
    const z = s.z_um || [];
    const p = r.plane || {};
    const pts = x.map((xi, i) => ({
      x: xi,
      y: y[i],
      v: z[i] - (p.offset_um + (p.slope_x_um_per_m / 1000) * xi + (p.slope_y_um_per_m / 1000) * y[i]),
    }));
    container.replaceChildren(
      renderColourMap(pts, { title: `Flatness of ${item.machine_id || ''}`.trim(), xLabel: 'X position (mm)', yLabel: 'Y position (mm)' }),
    );
    note.textContent =
      `Height at each point above (red) or below (blue) the least-squares plane, in µm` +
      `${meta.datum ? `; readings taken from the ${String(meta.datum).replace(/_/g, ' ')}` : ''}.`;
    return;
  }
  const x = s.position_mm || [];
  const d = s.deviation_um || [];
  const axis = meta.axis ? String(meta.axis).toUpperCase() : '';
  const xLabel = `Position along ${axis || 'the axis'} (mm)`;
  if (item.kind === 'parallelism') {
    // The datum is the reference of parallelism_um: the readings are drawn as they are, with
    // the least-squares line (its slope is slope_um_per_m) and the band of the readings.
    const mx = x.reduce((a, b) => a + b, 0) / n;
    const md = d.reduce((a, b) => a + b, 0) / n;
    const slope = r.slope_um_per_m / 1000;
    const lo = Math.min(...d);
    const hi = Math.max(...d);
    container.replaceChildren(
      renderProfilePlot({
        x,
        y: d,
        lines: [{ label: 'Least-squares line', cls: 'ls', y0: md - slope * mx, slope, testid: 'ls-line' }],
        bands: [{ label: `Parallelism ${formatNumber(hi - lo, '_um')} µm`, cls: 'zone', lo0: lo, hi0: hi, slope: 0, testid: 'parallelism-band' }],
        xLabel,
        yLabel: `Distance from the datum (µm)`,
        title: `Parallelism of ${axis || 'the axis'} to the ${meta.datum || 'datum'}`,
      }),
    );
    note.textContent = `Distance from the ${String(meta.datum || 'datum').replace(/_/g, ' ')} while ${axis || 'the axis'} travels; the shaded band is the parallelism (full range of the readings).`;
    return;
  }
  // Straightness: deviation about the least-squares line (intercept_um at 0 mm, slope_um_per_m).
  const lsSlope = r.slope_um_per_m / 1000;
  const res = x.map((xi, i) => d[i] - (r.intercept_um + lsSlope * xi));
  const lines = [{ label: 'Least-squares line', cls: 'ls', y0: 0, slope: 0, testid: 'ls-line' }];
  const bands = [];
  // Minimum-zone lines: slope min_zone_slope_um_per_m; in the residual their slope is the
  // difference of the slopes, and they touch the extreme points.
  let zone = null;
  if (typeof r.min_zone_slope_um_per_m === 'number' && res.length) {
    const k = (r.min_zone_slope_um_per_m - r.slope_um_per_m) / 1000;
    const u = res.map((v, i) => v - k * x[i]);
    const lo = Math.min(...u);
    const hi = Math.max(...u);
    // Use it only if it reproduces the reported minimum-zone straightness.
    if (Math.abs(hi - lo - r.straightness_min_zone_um) <= 1e-3 + 1e-6 * Math.abs(r.straightness_min_zone_um)) {
      zone = { label: `Minimum zone ${formatNumber(r.straightness_min_zone_um, '_um')} µm`, cls: 'zone', lo0: lo, hi0: hi, slope: k, testid: 'min-zone-band' };
    }
  }
  if (zone) bands.push(zone);
  else {
    bands.push({ label: `Least-squares band ${formatNumber(Math.max(...res) - Math.min(...res), '_um')} µm`, cls: 'zone', lo0: Math.min(...res), hi0: Math.max(...res), slope: 0, testid: 'ls-band' });
  }
  const errDir = meta.error_direction ? String(meta.error_direction).toUpperCase() : '';
  container.replaceChildren(
    renderProfilePlot({
      x,
      y: res,
      lines,
      bands,
      xLabel,
      yLabel: `Deviation${errDir ? ` in ${errDir}` : ''} (µm)`,
      title: `Straightness of ${axis || 'the axis'}${errDir ? ` in ${errDir}` : ''}`,
    }),
  );
  note.textContent =
    `Deviation after removing the least-squares line (slope ${formatNumber(r.slope_um_per_m, '_um_per_m')} µm/m); ` +
    (zone ? 'the shaded band is the minimum zone (two parallel lines enclosing all points).' : 'the shaded band is the least-squares band.');
}

// ---------------------------------------------------------------- PNG plot from the server

async function openPlotPng() {
  const id = state.measurementId;
  const button = $('#plot-png-button');
  if (!id) return;
  button.disabled = true;
  try {
    const blob = await api.plotPng(id);
    if (state.pngUrl) URL.revokeObjectURL(state.pngUrl);
    state.pngUrl = URL.createObjectURL(blob);
    const img = $('#png-image');
    img.src = state.pngUrl;
    img.dataset.measurementId = id;
    $('#png-download').href = state.pngUrl;
    $('#png-download').download = `kinemetric-${id}-polar.png`;
    $('#png-dialog').showModal();
  } catch (err) {
    if (!handleAuth(err)) $('#plot-note').replaceChildren(errorBox(err));
  } finally {
    button.disabled = false;
  }
}

function closePlotPng() {
  $('#png-dialog').close();
}

// ---------------------------------------------------------------- hexapod calibration

function dbbOfMachine() {
  return state.measurements.filter((m) => m.kind === 'dbb').sort((a, b) => a.id - b.id);
}

function resetCalibration() {
  state.calibSeq += 1; // stops any polling
  state.calibChecked = new Set();
  $('#calibration').hidden = true;
  $('#calib-measurements').replaceChildren();
  setMessage($('#calib-status'), null);
  $('#calib-results').replaceChildren();
}

// The panel lists the DBB tests of the selected machine; it is hidden when there are none.
function renderCalibrationChoices() {
  const dbb = dbbOfMachine();
  $('#calibration').hidden = dbb.length === 0;
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
  state.calibChecked = on ? new Set(dbbOfMachine().map((m) => m.id)) : new Set();
  for (const box of document.querySelectorAll('#calib-measurements input[type="checkbox"]')) box.checked = on;
}

function calibError(title, detail) {
  setMessage($('#calib-status'), 'error', h('strong', { class: 'problem-title' }, title), h('span', { class: 'problem-detail' }, detail));
}

async function onCalibrate(event) {
  event.preventDefault();
  const ids = dbbOfMachine()
    .map((m) => m.id)
    .filter((id) => state.calibChecked.has(id));
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
  const seq = ++state.calibSeq;
  const button = $('#calib-run');
  button.disabled = true;
  $('#calib-results').replaceChildren();
  setMessage($('#calib-status'), 'info', `Submitting a calibration with ${ids.length} DBB test${ids.length === 1 ? '' : 's'}…`);
  try {
    const { job_id: jobId } = await api.calibrate(body);
    $('#calib-status').dataset.jobId = jobId;
    await pollJob(jobId, seq);
  } catch (err) {
    if (seq !== state.calibSeq) return;
    if (!handleAuth(err)) setMessage($('#calib-status'), 'error', ...problemContent(err instanceof ApiError ? err : { title: 'Calibration failed', detail: String(err.message || err) }));
  } finally {
    if (seq === state.calibSeq) button.disabled = false;
  }
}

function jobStatusContent(job) {
  const pct = Math.round(100 * (Number(job.progress) || 0));
  return [
    h('strong', { class: 'problem-title' }, `Job #${job.id}: ${job.status}`),
    h('span', { class: 'job-stage', 'data-testid': 'calib-stage' }, `${job.stage || ''}`.replace(/_/g, ' ')),
    h('progress', { max: 100, value: pct, 'data-testid': 'calib-progress' }, `${pct} %`),
  ];
}

async function pollJob(jobId, seq) {
  const status = $('#calib-status');
  for (;;) {
    const job = await api.job(jobId);
    if (seq !== state.calibSeq) return;
    status.dataset.status = job.status;
    if (job.status === 'done') {
      setMessage(status, 'success', h('strong', { class: 'problem-title' }, `Job #${job.id}: done`), h('span', {}, 'Calibration finished.'));
      renderCalibrationResult(job.result || {});
      return;
    }
    if (job.status === 'failed') {
      setMessage(status, 'error', h('strong', { class: 'problem-title' }, `Job #${job.id}: failed`), h('span', { class: 'problem-detail', 'data-testid': 'calib-error' }, job.error || 'no reason given'));
      return;
    }
    setMessage(status, 'info', ...jobStatusContent(job));
    await new Promise((r) => setTimeout(r, JOB_POLL_MS));
    if (seq !== state.calibSeq) return;
  }
}

function renderCalibrationResult(r) {
  const f3 = (v) => formatNumber(v, '_um');
  const tests = Array.isArray(r.tests) ? r.tests : [];
  const testsTable = h(
    'table',
    { class: 'figures small calib-tests', 'data-testid': 'calib-tests-table' },
    h('caption', {}, 'Before and predicted after the correction ([PM-600 report] table 2.2: centre deviation, average radial error, circularity)'),
    h(
      'thead',
      {},
      h(
        'tr',
        {},
        h('th', { scope: 'col' }, 'Test'),
        h('th', { scope: 'col' }, 'Direction'),
        h('th', { scope: 'col', class: 'num' }, 'Centre dev. before (µm)'),
        h('th', { scope: 'col', class: 'num' }, 'after (µm)'),
        h('th', { scope: 'col', class: 'num' }, 'Avg radial err. before (µm)'),
        h('th', { scope: 'col', class: 'num' }, 'after (µm)'),
        h('th', { scope: 'col', class: 'num' }, 'Before (µm)'),
        h('th', { scope: 'col', class: 'num' }, 'Predicted after (µm)'),
      ),
    ),
    h(
      'tbody',
      {},
      ...tests.map((t, i) =>
        h(
          'tr',
          { 'data-index': i },
          h('td', { 'data-key': 'test_id' }, t.test_id ?? '—'),
          h('td', { 'data-key': 'direction' }, formatDirection(t.direction)),
          h('td', { class: 'num', 'data-key': 'centre_deviation_before_um' }, f3(t.centre_deviation_before_um)),
          h('td', { class: 'num', 'data-key': 'centre_deviation_predicted_after_um' }, f3(t.centre_deviation_predicted_after_um)),
          h('td', { class: 'num', 'data-key': 'average_radial_error_before_um' }, f3(t.average_radial_error_before_um)),
          h('td', { class: 'num', 'data-key': 'average_radial_error_predicted_after_um' }, f3(t.average_radial_error_predicted_after_um)),
          h('td', { class: 'num', 'data-key': 'circularity_before_um' }, f3(t.circularity_before_um)),
          h('td', { class: 'num', 'data-key': 'predicted_circularity_after_um' }, f3(t.predicted_circularity_after_um)),
        ),
      ),
    ),
  );
  const p = r.parameters || {};
  const u = r.parameter_uncertainty_um || {};
  const fixed = new Set(Array.isArray(r.fixed_parameters) ? r.fixed_parameters : []);
  const cell = (name, v, s) =>
    h(
      'td',
      { class: `num${fixed.has(name) ? ' fixed' : ''}`, 'data-param': name, title: fixed.has(name) ? 'fixed (not identifiable from these tests)' : null },
      fixed.has(name) ? `${f3(v)} (fixed)` : `${f3(v)} ± ${f3(s)}`,
    );
  const paramsTable = h(
    'table',
    { class: 'figures small calib-params', 'data-testid': 'calib-params-table' },
    h('caption', {}, 'Identified parameters (µm, ± standard uncertainty)'),
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
  const summary = h(
    'dl',
    { class: 'calib-summary', 'data-testid': 'calib-summary' },
    h('dt', {}, 'Method'),
    h('dd', { 'data-key': 'method' }, formatMode(r.method)),
    h('dt', {}, 'Residual RMS'),
    h('dd', { 'data-key': 'residual_rms_um' }, `${f3(r.residual_rms_um)} µm`),
    h('dt', {}, 'Condition number'),
    h('dd', { 'data-key': 'condition_number' }, formatNumber(r.condition_number)),
    h('dt', {}, 'Converged'),
    h('dd', { 'data-key': 'converged' }, r.converged === undefined ? '—' : r.converged ? `yes (${r.iterations ?? '?'} iterations)` : 'no'),
    h('dt', {}, 'Fixed parameters'),
    h('dd', { 'data-key': 'fixed_parameters' }, fixed.size ? [...fixed].join(', ') : 'none'),
  );
  $('#calib-results').replaceChildren(summary, testsTable, paramsTable);
}

// ---------------------------------------------------------------- upload

async function onUpload(event) {
  event.preventDefault();
  const input = $('#upload-file');
  const msg = $('#upload-message');
  const button = $('#upload-button');
  const file = input.files && input.files[0];
  if (!file) {
    setMessage(msg, 'error', h('strong', { class: 'problem-title' }, 'No file chosen'), h('span', { class: 'problem-detail' }, 'Choose a measurement file first.'));
    input.focus();
    return;
  }
  button.disabled = true;
  setMessage(msg, 'info', `Uploading “${file.name}”…`);
  try {
    const bytes = await file.arrayBuffer();
    const res = await api.upload(file, bytes);
    clearAuthProblem();
    const text = res.created
      ? `Uploaded “${file.name}” — stored as measurement #${res.id}.`
      : `“${file.name}” was already stored (identical file) as measurement #${res.id}.`;
    setMessage(msg, 'success', text);
    msg.dataset.measurementId = res.id;
    $('#upload-form').reset();
    // Show what was uploaded: its machine, then the measurement itself.
    let machineId = null;
    try {
      machineId = (await api.measurement(res.id)).machine_id;
    } catch (err) {
      handleAuth(err);
    }
    if (machineId) {
      await loadMachines({ select: machineId, selectMeasurement: res.id });
    } else {
      await loadMachines();
    }
  } catch (err) {
    delete msg.dataset.measurementId;
    if (err instanceof ApiError && err.status === 401) {
      showAuthProblem(err);
      setMessage(msg, 'error', h('strong', { class: 'problem-title' }, 'Not uploaded'), h('span', { class: 'problem-detail' }, 'An access token is needed (see the message at the top).'));
    } else if (err instanceof ApiError && err.status === 413) {
      setMessage(msg, 'error', ...problemContent({ ...err, title: err.title || 'File too large', detail: err.detail || 'The file is larger than the server accepts.' }));
    } else {
      setMessage(msg, 'error', ...problemContent(err instanceof ApiError ? err : { title: 'Upload failed', detail: String(err.message || err) }));
    }
  } finally {
    button.disabled = false;
  }
}

// ---------------------------------------------------------------- start

function onTokenSubmit(event) {
  event.preventDefault();
  const value = $('#token-input').value.trim();
  if (!value) {
    $('#token-input').focus();
    return;
  }
  setToken(value);
  $('#token-input').value = '';
  updateTokenStatus();
  clearAuthProblem();
  loadMachines();
  applyRoute();
}

function onTokenForget() {
  setToken('');
  updateTokenStatus();
  state.machines = [];
  state.machineId = null;
  state.measurements = [];
  renderMachines();
  $('#measurements').replaceChildren();
  $('#measurements-machine').textContent = 'Select a machine.';
  $('#measurements-count').textContent = '';
  resetDetail();
  resetCalibration();
  showAuthProblem(null);
}

function start() {
  takeTokenFromFragment();
  updateTokenStatus();
  $('#token-form').addEventListener('submit', onTokenSubmit);
  $('#token-forget').addEventListener('click', onTokenForget);
  $('#upload-form').addEventListener('submit', onUpload);
  $('#machines-refresh').addEventListener('click', () => loadMachines());
  $('#plot-png-button').addEventListener('click', openPlotPng);
  $('#png-close').addEventListener('click', closePlotPng);
  $('#calib-form').addEventListener('submit', onCalibrate);
  $('#calib-all').addEventListener('click', () => setAllCalibChecks(true));
  $('#calib-none').addEventListener('click', () => setAllCalibChecks(false));
  $('#png-dialog').addEventListener('click', (e) => {
    if (e.target === e.currentTarget) closePlotPng(); // click on the backdrop
  });
  window.addEventListener('hashchange', () => {
    if (takeTokenFromFragment()) {
      updateTokenStatus();
      loadMachines();
    }
    applyRoute();
  });
  initStreams();
  initDiscovery({
    getMachineId: () => state.machineId,
    getMachines: () => state.machines,
    getMeasurements: () => state.measurements,
    handleAuth,
    // A machine the list does not know yet (uploaded meanwhile): the list is reloaded first.
    selectMachine: (id) =>
      state.machines.some((m) => m.machine_id === id) ? selectMachine(id) : loadMachines({ select: id }),
    reloadMachines: () => loadMachines(),
  });
  resetDetail();
  if (!getToken()) {
    showAuthProblem(null);
    $('#machines').replaceChildren(h('li', { class: 'empty' }, 'Waiting for an access token…'));
  } else {
    applyRoute();
    loadMachines({ select: parseRoute().machine || undefined });
    refreshStreams();
  }
  document.body.dataset.ready = 'true';
}

start();
