// The measurement list of the selected machine: one page of the server's answer (newest first by
// default), filters by kind, test, date range and free text, a key result per row, paging, and
// CSV export of the page.

import { api } from './api.js';
import { handleAuth } from './auth.js';
import { $, downloadText, errorBox, h, keepFocus, toCsv } from './dom.js';
import { formatDirection, formatNumber, formatTimestamp } from './format.js';
import { measurementHash, navigate } from './router.js';
import { PAGE_SIZE, state } from './state.js';
import { conformanceBadge } from './tolerances.js';

export function resetFilters() {
  state.filters = { kind: '', test_id: '', from: '', to: '', q: '', order: 'newest' };
  const form = $('#list-filters');
  form.reset();
  $('#filter-order').value = 'newest';
}

// The date inputs give a day; the server takes ISO 8601 times ("to" exclusive: the next day).
function dayStart(day) {
  return day ? `${day}T00:00:00Z` : '';
}
function dayAfter(day) {
  if (!day) return '';
  const d = new Date(`${day}T00:00:00Z`);
  d.setUTCDate(d.getUTCDate() + 1);
  return d.toISOString().replace(/\.\d{3}Z$/, 'Z');
}

function query(offset) {
  const f = state.filters;
  return {
    limit: PAGE_SIZE,
    offset,
    kind: f.kind,
    test_id: f.test_id.trim(),
    from: dayStart(f.from),
    to: dayAfter(f.to),
    q: f.q.trim(),
    order: f.order,
  };
}

// Loads one page of the list for the current filters; returns its items. When another load
// overtakes it, the answer is that one's (what the list finally shows).
let latest = null;
export function loadMeasurementPage(options) {
  const mine = fetchPage(options);
  latest = mine;
  return mine.then((items) => (items === null && latest !== mine ? latest : items));
}

async function fetchPage({ offset = state.list.offset } = {}) {
  const machineId = state.machineId;
  if (!machineId) return null;
  const seq = ++state.listSeq;
  const list = $('#measurements');
  list.setAttribute('aria-busy', 'true');
  try {
    const data = await api.measurements(machineId, query(offset));
    if (seq !== state.listSeq || state.machineId !== machineId) return null;
    state.list = { items: data.items || [], total: data.total ?? 0, offset };
    renderMeasurements();
    return state.list.items;
  } catch (err) {
    if (seq === state.listSeq && !handleAuth(err)) list.replaceChildren(h('li', { class: 'empty' }, errorBox(err)));
    return null;
  } finally {
    if (seq === state.listSeq) list.removeAttribute('aria-busy');
  }
}

function keyResultText(m) {
  const k = m.key_result;
  if (!k || typeof k.value !== 'number') return '';
  return `${k.label} ${formatNumber(k.value, k.name)} ${k.unit || ''}`.trim();
}

function timeText(m) {
  // Measurement time from the file; upload time when the file has none (labelled so).
  return m.timestamp ? `measured ${formatTimestamp(m.timestamp)}` : `uploaded ${formatTimestamp(m.uploaded_at)}`;
}

export function renderMeasurements() {
  const list = $('#measurements');
  const { items, total, offset } = state.list;
  const first = items.length ? offset + 1 : 0;
  const last = offset + items.length;
  $('#measurements-count').textContent = `${total}`;
  $('#list-range').textContent = total ? `${first}–${last} of ${total}` : 'none';
  $('#list-prev').disabled = offset <= 0;
  $('#list-next').disabled = last >= total;
  $('#list-pager').dataset.offset = String(offset);
  $('#list-pager').dataset.total = String(total);
  if (!items.length) {
    list.replaceChildren(
      h('li', { class: 'empty' }, total === 0 && !anyFilter() ? 'No measurements for this machine.' : 'No measurement matches the filters.'),
    );
    return;
  }
  keepFocus(list, () =>
    list.replaceChildren(
      ...items.map((m) =>
        h(
          'li',
          {},
          h(
            'a',
            {
              class: 'item',
              href: measurementHash(m.id),
              'data-testid': 'measurement-item',
              'data-id': m.id,
              'data-kind': m.kind,
              'data-test-id': m.test_id ?? '',
              'data-direction': m.direction ?? '',
              'data-focus-key': `m:${m.id}`,
              'aria-current': m.id === state.measurementId ? 'true' : 'false',
            },
            h(
              'span',
              { class: 'item-title' },
              m.test_id || m.filename || `#${m.id}`,
              m.direction ? h('span', { class: `badge dir-${m.direction}` }, formatDirection(m.direction)) : '',
              h('span', { class: 'item-id' }, `#${m.id}`),
            ),
            keyResultText(m) ? h('span', { class: 'item-key', 'data-testid': 'key-result' }, keyResultText(m)) : '',
            // The measurement judged against the machine's newest tolerances.
            m.conformance ? h('span', { class: 'item-conformance' }, 'tolerances ', conformanceBadge(m.conformance, 'measurement-conformance')) : '',
            h('span', { class: 'item-meta' }, [String(m.kind || '').toUpperCase(), timeText(m), m.filename].filter(Boolean).join(' · ')),
          ),
        ),
      ),
    ),
  );
}

function anyFilter() {
  const f = state.filters;
  return Boolean(f.kind || f.test_id || f.from || f.to || f.q);
}

// Marks the shown measurement in the list (without reloading it).
export function markCurrent() {
  for (const a of document.querySelectorAll('#measurements [data-testid="measurement-item"]')) {
    a.setAttribute('aria-current', Number(a.dataset.id) === state.measurementId ? 'true' : 'false');
  }
}

function readFilters() {
  state.filters = {
    kind: $('#filter-kind').value,
    test_id: $('#filter-test').value,
    from: $('#filter-from').value,
    to: $('#filter-to').value,
    q: $('#filter-q').value,
    order: $('#filter-order').value || 'newest',
  };
}

async function exportCsv() {
  // Every measurement matching the filters (up to 10 000), not only the page shown.
  const rows = [['id', 'kind', 'test_id', 'direction', 'measured_at', 'uploaded_at', 'filename', 'key_result', 'value', 'unit']];
  for (let offset = 0; offset < 10_000; offset += 1000) {
    const page = await api.measurements(state.machineId, { ...query(offset), limit: 1000 });
    for (const m of page.items || []) {
      const k = m.key_result || {};
      rows.push([m.id, m.kind, m.test_id, m.direction, m.timestamp, m.uploaded_at, m.filename, k.name, k.value, k.unit]);
    }
    if (offset + 1000 >= (page.total ?? 0)) break;
  }
  downloadText(toCsv(rows), `kinemetric-${state.machineId}-measurements.csv`, 'text/csv');
}

export function initMeasurementList() {
  let timer = null;
  const apply = () => {
    readFilters();
    loadMeasurementPage({ offset: 0 });
  };
  $('#list-filters').addEventListener('submit', (e) => {
    e.preventDefault();
    clearTimeout(timer);
    apply();
  });
  for (const id of ['#filter-kind', '#filter-order', '#filter-from', '#filter-to']) $(id).addEventListener('change', apply);
  for (const id of ['#filter-q', '#filter-test']) {
    $(id).addEventListener('input', () => {
      clearTimeout(timer);
      timer = setTimeout(apply, 250);
    });
  }
  $('#list-filters').addEventListener('reset', () => {
    setTimeout(() => {
      $('#filter-order').value = 'newest';
      apply();
    });
  });
  $('#list-prev').addEventListener('click', () => loadMeasurementPage({ offset: Math.max(0, state.list.offset - PAGE_SIZE) }));
  $('#list-next').addEventListener('click', () => loadMeasurementPage({ offset: state.list.offset + PAGE_SIZE }));
  $('#list-csv').addEventListener('click', () => exportCsv().catch((err) => handleAuth(err)));
  // A new tolerance table judges every measurement again: the page shown is read again.
  window.addEventListener('km-tolerances-changed', (e) => {
    if (e.detail?.machineId === state.machineId) loadMeasurementPage();
  });
  $('#measurements').addEventListener('click', (e) => {
    const a = e.target.closest('a[data-testid="measurement-item"]');
    if (!a || e.ctrlKey || e.metaKey || e.shiftKey) return;
    e.preventDefault();
    // One column (narrow screens): the view is under the list, so it is brought into sight.
    state.scrollToDetail = window.matchMedia('(max-width: 1000px)').matches;
    navigate(measurementHash(Number(a.dataset.id)));
  });
}
