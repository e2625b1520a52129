// kinemetric dashboard: machines → measurements → DBB polar plot and figures, plus upload.
// Plain ES module, no build step, nothing loaded from outside the server.

import { api, ApiError, getToken, setToken, takeTokenFromFragment } from './api.js';
import {
  formatDirection,
  formatMode,
  formatNumber,
  formatTimestamp,
  labelOf,
  unitOf,
} from './format.js';
import { renderPolarPlot } from './polar.js';

const $ = (sel) => document.querySelector(sel);

const state = {
  machines: [],
  machineId: null,
  measurements: [],
  measurementId: null,
  selectSeq: 0, // guards against out-of-order responses when clicking quickly
};

// ---------------------------------------------------------------- small DOM helpers

function h(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null || v === false) continue;
    if (k === 'class') node.className = v;
    else if (k === 'dataset') Object.assign(node.dataset, v);
    else if (k.startsWith('on')) node.addEventListener(k.slice(2), v);
    else node.setAttribute(k, v === true ? '' : String(v));
  }
  for (const c of children.flat()) {
    if (c === undefined || c === null || c === false) continue;
    node.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
  return node;
}

function setMessage(node, kind, ...content) {
  node.replaceChildren(...content);
  node.classList.remove('error', 'success', 'info');
  node.hidden = content.length === 0;
  if (kind) node.classList.add(kind);
  // Errors are announced immediately; other messages politely.
  node.setAttribute('role', kind === 'error' ? 'alert' : 'status');
}

function problemContent(err) {
  const parts = [h('strong', { class: 'problem-title' }, err.title || 'Error')];
  if (err.detail) parts.push(h('span', { class: 'problem-detail' }, err.detail));
  const where = [];
  if (err.file) where.push(`file ${err.file}`);
  if (err.line !== undefined && err.line !== null) where.push(`line ${err.line}`);
  if (err.field) where.push(`field “${err.field}”`);
  if (where.length) parts.push(h('span', { class: 'problem-where' }, where.join(', ')));
  return parts;
}

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

function errorBox(err) {
  const box = h('div', { class: 'message error', role: 'alert' });
  box.append(...problemContent(err instanceof ApiError ? err : { title: 'Error', detail: String(err.message || err) }));
  return box;
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
            onclick: () => selectMachine(m.machine_id),
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
  }
  try {
    const data = await api.measurements(machineId);
    if (state.machineId !== machineId) return; // another machine was clicked meanwhile
    state.measurements = data.items || [];
    const total = data.total ?? state.measurements.length;
    $('#measurements-count').textContent =
      total > state.measurements.length ? `showing ${state.measurements.length} of ${total}` : `${total}`;
    renderMeasurements();
    const target = selectMeasurement ?? state.measurementId;
    // Keep the selection; otherwise show the newest DBB test of the machine straight away.
    const item =
      state.measurements.find((m) => m.id === target) ||
      state.measurements.filter((m) => m.kind === 'dbb').sort((x, y) => y.id - x.id)[0];
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
            onclick: () => selectMeasurementItem(m),
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
    h('p', { class: 'placeholder' }, 'Select a DBB measurement to see its polar plot.'),
  );
  $('#figures').replaceChildren(h('p', { class: 'placeholder' }, 'Figures appear here.'));
  $('#figures-extra').replaceChildren();
}

async function selectMeasurementItem(item) {
  const seq = ++state.selectSeq;
  state.measurementId = item.id;
  renderMeasurements();
  const partner = partnerOf(item);
  const items = [item, partner].filter(Boolean);
  // Fixed order: CCW first, then CW, so colours and columns do not swap between clicks.
  items.sort((a, b) => (a.direction === 'ccw' ? 0 : 1) - (b.direction === 'ccw' ? 0 : 1));

  $('#detail-heading').textContent = `${item.test_id || item.filename || `Measurement #${item.id}`} — ${item.machine_id || state.machineId}`;
  $('#polar-plot').setAttribute('aria-busy', 'true');
  $('#figures').setAttribute('aria-busy', 'true');
  try {
    const wantTrace = item.kind === 'dbb';
    const settled = await Promise.allSettled(
      items.map(async (m) => {
        const [results, trace] = await Promise.all([
          api.results(m.id),
          wantTrace ? api.trace(m.id) : Promise.resolve(null),
        ]);
        return { item: m, results, trace };
      }),
    );
    if (seq !== state.selectSeq) return;
    // The selected measurement must evaluate; a partner that does not is reported and left out.
    const own = settled[items.indexOf(item)];
    if (own.status === 'rejected') throw own.reason;
    const fetched = settled.filter((r) => r.status === 'fulfilled').map((r) => r.value);
    renderPlot(item, fetched);
    renderFigures(fetched);
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
  if (item.kind !== 'dbb') {
    container.replaceChildren(
      h('p', { class: 'placeholder' }, `No polar plot for ${String(item.kind).toUpperCase()} measurements.`),
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

// Flattens one results object into {key: value} rows; arrays of objects are returned apart.
function flattenResults(results) {
  const flat = {};
  const tables = {};
  for (const [key, value] of Object.entries(results || {})) {
    if (key === 'centre_offset_um' && Array.isArray(value)) {
      flat.centre_offset_x_um = value[0];
      flat.centre_offset_y_um = value[1];
    } else if (typeof value === 'number' || typeof value === 'string' || typeof value === 'boolean') {
      flat[key] = value;
    } else if (Array.isArray(value)) {
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
  return String(value);
}

function rowLabel(key) {
  const [parent, leaf] = key.includes('.') ? key.split('.', 2) : [null, key];
  const label = labelOf(leaf);
  if (!parent || /ISO 230-4/.test(label)) return label;
  return `${labelOf(parent)}: ${label.charAt(0).toLowerCase()}${label.slice(1)}`;
}

function renderFigures(fetched) {
  const columns = fetched.map((f) => ({ item: f.item, ...flattenResults(f.results) }));
  // Row order: the lead rows, then every other numeric key, then other values (e.g. versions).
  const seen = new Set();
  const keys = [];
  const push = (k) => {
    if (!seen.has(k)) {
      seen.add(k);
      keys.push(k);
    }
  };
  LEAD_ROWS.forEach(push);
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
          c.item.direction ? formatDirection(c.item.direction) : `#${c.item.id}`,
          h('span', { class: 'col-id' }, ` #${c.item.id}`),
        ),
      ),
    ),
  );
  const tbody = h('tbody');
  for (const key of keys) {
    if (columns.every((c) => c.flat[key] === undefined) && !LEAD_ROWS.slice(0, 2).includes(key)) continue;
    const leaf = key.split('.').pop();
    const numeric = isNumeric(key);
    const { unit } = unitOf(leaf);
    tbody.append(
      h(
        'tr',
        { 'data-key': key, class: LEAD_ROWS.includes(key) ? 'lead' : '' },
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
  const table = h('table', { class: 'figures', 'data-testid': 'figures-table' }, h('caption', {}, 'DBB figures'), thead, tbody);
  $('#figures').replaceChildren(table);
  renderExtraTables(columns);
}

// Arrays of objects (e.g. harmonics[], diagnosis[]) as small tables, folded by default.
function renderExtraTables(columns) {
  const box = $('#figures-extra');
  const names = [...new Set(columns.flatMap((c) => Object.keys(c.tables)))];
  const blocks = [];
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

function labelWithUnit(key) {
  const { unit } = unitOf(key);
  return unit ? `${labelOf(key)} (${unit})` : labelOf(key);
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
  showAuthProblem(null);
}

function start() {
  takeTokenFromFragment();
  updateTokenStatus();
  $('#token-form').addEventListener('submit', onTokenSubmit);
  $('#token-forget').addEventListener('click', onTokenForget);
  $('#upload-form').addEventListener('submit', onUpload);
  $('#machines-refresh').addEventListener('click', () => loadMachines());
  window.addEventListener('hashchange', () => {
    if (takeTokenFromFragment()) {
      updateTokenStatus();
      loadMachines();
    }
  });
  resetDetail();
  if (!getToken()) {
    showAuthProblem(null);
    $('#machines').replaceChildren(h('li', { class: 'empty' }, 'Waiting for an access token…'));
  } else {
    loadMachines();
  }
  document.body.dataset.ready = 'true';
}

start();
