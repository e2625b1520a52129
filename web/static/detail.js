// The view of one measurement (#/measurements/{id}): for a DBB test the polar plot, figures and
// diagnosis of exactly the pair the server's /pair analyses (data-measurement-id and
// data-partner-id on the view, and a note naming the partner's file); form and tracker plots;
// test conditions; the server's PNG plot; print and CSV export.

import { api } from './api.js';
import { handleAuth } from './auth.js';
import { $, downloadText, errorBox, h, toCsv } from './dom.js';
import { renderAnalysis, resetAnalysis } from './diagnosis.js';
import { renderFigures } from './figures.js';
import { formatDirection, formatNumber, formatTimestamp } from './format.js';
import { formSetup, renderFormPlot, renderRotaryView, renderTrackerPlot } from './formplots.js';
import { resetReversal, showReversal } from './reversal.js';
import { markCurrent } from './measurements.js';
import { renderPolarPlot } from './polar.js';
import { renderServoForce } from './servo.js';
import { shell } from './shell.js';
import { compensationBlock, positioningConditions, renderPositioningPlot } from './positioning.js';
import { FORM_KINDS, WIDE_KINDS, state } from './state.js';
import { conformancePanel } from './tolerances.js';
import { hideCertificate, showMeasurementCertificate } from './reports.js';

export function resetDetail() {
  const view = $('#detail');
  view.dataset.view = 'none';
  delete view.dataset.measurementId;
  delete view.dataset.partnerId;
  $('#detail-heading').textContent = 'Polar plot and figures';
  $('#plot-note').textContent = '';
  $('#pair-note').hidden = true;
  $('#pair-note').replaceChildren();
  shownDbb = null;
  overlay = null;
  renderCompareNote();
  $('#conditions').replaceChildren();
  $('#detail-actions').hidden = true;
  $('#polar-plot').replaceChildren(h('p', { class: 'placeholder' }, 'Select a measurement to see its plot.'));
  $('#figures').replaceChildren(h('p', { class: 'placeholder' }, 'Figures appear here.'));
  $('#figures-extra').replaceChildren();
  renderConformance(null);
  hideCertificate('measurement');
  resetReversal();
  resetAnalysis();
  setDetailLayout(null);
}

// The measurement's conformance with its machine's newest tolerances, above its figures: the
// verdict and each figure with value, tolerance and verdict.
function renderConformance(conformance) {
  let box = $('#conformance');
  if (!box) {
    box = h('div', { id: 'conformance', class: 'conformance' });
    $('#figures').before(box);
  }
  box.replaceChildren(conformance ? conformancePanel(conformance) : '');
}

// The results without the conformance the server adds to them (shown on its own, not as figures).
function splitConformance(results) {
  if (!results || typeof results !== 'object' || !('conformance' in results)) return { results, conformance: null };
  const { conformance, ...rest } = results;
  return { results: rest, conformance };
}

// DBB: polar plot beside the figures; form measurements: the wide plot above the figures.
function setDetailLayout(kind) {
  const wide = WIDE_KINDS.includes(kind);
  $('#detail-body').classList.toggle('wide', wide);
  $('#polar-plot').classList.toggle('polar-figure', !wide);
}

function itemOf(m) {
  const { samples, metadata, ...item } = m;
  return item;
}

function detailHeading(item) {
  const machine = item.machine_id || state.machineId;
  if (item.kind === 'dbb') return `${item.test_id || item.filename || `Measurement #${item.id}`} — ${machine}`;
  const kind = String(item.kind || 'measurement');
  const what = `${kind.charAt(0).toUpperCase()}${kind.slice(1)}`;
  return `${what} ${item.test_id ? `${item.test_id} ` : ''}· ${item.filename || `#${item.id}`} — ${machine}`;
}

// Everything one DBB file of the pair needs: metadata, results, trace.
async function fetchDbbFile(id, measurement) {
  const [m, judged, trace] = await Promise.all([
    measurement ? Promise.resolve(measurement) : api.measurement(id),
    api.results(id),
    api.trace(id),
  ]);
  const { results, conformance } = splitConformance(judged);
  return { item: itemOf(m), metadata: m.metadata || {}, results, trace, conformance };
}

// Shows measurement `id`: selects its machine in the sidebar first (a deep link, a reload).
export async function showMeasurement(id) {
  const seq = ++state.selectSeq;
  state.measurementId = id;
  markCurrent();
  const view = $('#detail');
  $('#polar-plot').setAttribute('aria-busy', 'true');
  $('#figures').setAttribute('aria-busy', 'true');
  try {
    const measurement = await api.measurement(id);
    if (seq !== state.selectSeq) return;
    if (measurement.machine_id !== state.machineId) {
      await shell.selectMachine(measurement.machine_id);
      if (seq !== state.selectSeq) return;
      state.measurementId = id;
      markCurrent();
    }
    const item = itemOf(measurement);
    $('#detail-heading').textContent = detailHeading(item);
    if (item.kind === 'dbb') resetReversal();
    if (item.kind === 'dbb') await showDbb(seq, item, measurement);
    else await showOther(seq, item, measurement);
    if (seq !== state.selectSeq) return;
    view.dataset.measurementId = String(id);
    $('#detail-actions').hidden = false;
    showMeasurementCertificate(item); // the report exists: its certificate beside its button
    if (state.scrollToDetail) {
      state.scrollToDetail = false;
      view.scrollIntoView({ block: 'start' });
    }
  } catch (err) {
    if (seq !== state.selectSeq) return;
    hideCertificate('measurement');
    if (!handleAuth(err)) {
      view.dataset.view = 'error';
      $('#polar-plot').replaceChildren(errorBox(err));
      $('#figures').replaceChildren();
      $('#figures-extra').replaceChildren();
      $('#conditions').replaceChildren();
      resetAnalysis();
    }
  } finally {
    if (seq === state.selectSeq) {
      $('#polar-plot').removeAttribute('aria-busy');
      $('#figures').removeAttribute('aria-busy');
    }
  }
}

async function showOther(seq, item, measurement) {
  const { results, conformance } = splitConformance(await api.results(item.id));
  if (seq !== state.selectSeq) return;
  renderConformance(conformance);
  const fetched = [{ item, results, trace: null, measurement }];
  const view = $('#detail');
  view.dataset.view = item.kind;
  delete view.dataset.partnerId;
  resetReversal();
  $('#pair-note').hidden = true;
  shownDbb = null;
  renderCompareNote();
  setDetailLayout(item.kind);
  resetAnalysis();
  if (item.kind === 'straightness') showReversal(item, measurement, () => seq === state.selectSeq).catch(() => {});
  if (FORM_KINDS.includes(item.kind)) renderFormPlot(item, fetched[0]);
  else if (item.kind === 'tracker') renderTrackerPlot(item, fetched[0]);
  else if (item.kind === 'positioning') renderPositioningPlot(item, fetched[0]);
  else if (item.kind === 'rotary') renderRotaryView(item, fetched[0]);
  else if (item.kind === 'servo' && results.record === 'hexapod') await renderServoForce(item, () => seq === state.selectSeq);
  else {
    $('#polar-plot').replaceChildren(h('p', { class: 'placeholder' }, `No plot for ${String(item.kind).toUpperCase()} measurements yet.`));
    $('#plot-note').textContent = '';
  }
  renderFigures(fetched, { kind: item.kind });
  renderConditions([{ item, metadata: measurement.metadata || {} }]);
  if (FORM_KINDS.includes(item.kind)) $('#conditions').prepend(formSetup(item, measurement.metadata || {}, results));
  if (item.kind === 'positioning') {
    $('#conditions').append(positioningConditions(results));
    $('#figures-extra').prepend(compensationBlock(item));
  }
}

// The test and, when the server pairs it, exactly the partner /pair names. /pair is asked only
// when the measurement names a partner (partner_id; a server without it is asked anyway).
async function showDbb(seq, item, measurement) {
  const paired = measurement.partner_id !== null;
  const [own, pair] = await Promise.all([fetchDbbFile(item.id, measurement), paired ? api.pair(item.id).catch((err) => ({ error: err })) : null]);
  if (seq !== state.selectSeq) return;
  const pairError = pair && pair.error ? pair.error : null;
  if (pairError && handleAuth(pairError)) return;
  const pairData = pairError ? null : pair;
  let partner = null;
  let partnerError = null;
  if (pairData && pairData.partner_id) {
    try {
      partner = await fetchDbbFile(pairData.partner_id);
    } catch (err) {
      if (handleAuth(err)) return;
      partnerError = err;
    }
    if (seq !== state.selectSeq) return;
  }
  // Fixed order: CCW first, then CW, so colours and columns do not swap between clicks.
  const fetched = [own, partner].filter(Boolean);
  fetched.sort((a, b) => (a.item.direction === 'ccw' ? 0 : 1) - (b.item.direction === 'ccw' ? 0 : 1));
  const view = $('#detail');
  view.dataset.view = 'dbb';
  if (pairData && pairData.partner_id) view.dataset.partnerId = String(pairData.partner_id);
  else delete view.dataset.partnerId;
  setDetailLayout('dbb');
  renderDbbPlot(item, fetched);
  renderConformance(own.conformance);
  renderPairNote(item, pairData, partner, partnerError);
  renderFigures(fetched, { kind: 'dbb', pair: partner ? pairData : null });
  renderAnalysis(item, fetched, partner ? pairData : null, pairError);
  renderConditions(fetched);
}

function describeFile(f) {
  const when = f.item.timestamp ? `measured ${formatTimestamp(f.item.timestamp)}` : `uploaded ${formatTimestamp(f.item.uploaded_at)}`;
  return `${formatDirection(f.item.direction)} #${f.item.id}${f.item.filename ? ` (${f.item.filename})` : ''}, ${when}`;
}

function renderPairNote(item, pair, partner, partnerError) {
  const note = $('#pair-note');
  note.hidden = false;
  if (!pair || !pair.partner_id) {
    note.dataset.partnerId = '';
    note.replaceChildren(`No ${item.direction === 'cw' ? 'CCW' : 'CW'} test of this machine and test is paired with #${item.id}.`);
    return;
  }
  note.dataset.partnerId = String(pair.partner_id);
  if (partnerError) {
    note.replaceChildren(
      `Paired with #${pair.partner_id}, which could not be evaluated: ${partnerError.detail || partnerError.message}`,
    );
    return;
  }
  note.replaceChildren(
    h('strong', {}, 'Pair: '),
    `this test ${describeFile({ item })} with `,
    h('a', { href: `#/measurements/${pair.partner_id}`, 'data-testid': 'partner-link' }, describeFile(partner)),
    ' — the pair the server analyses: the opposite-direction file of this test measured nearest in time.',
  );
}

// The DBB test shown (for redrawing with an overlay) and the overlaid test, if any.
let shownDbb = null;
let overlay = null;
const OVERLAY_STYLE = { colour: '#6b7785', dash: '2 3' };

function renderDbbPlot(item, fetched) {
  shownDbb = { item, fetched };
  const traces = fetched
    .filter((f) => f.trace)
    .map((f) => ({ ...f.trace, direction: f.trace.direction || f.item.direction, test_id: f.item.test_id, id: f.item.id }));
  if (overlay && !fetched.some((f) => f.item.id === overlay.item.id)) {
    const o = overlay;
    traces.push({
      ...o.trace,
      direction: o.item.direction,
      id: o.item.id,
      role: 'compare',
      style: { ...OVERLAY_STYLE, label: `#${o.item.id} ${formatDirection(o.item.direction)} (overlay)` },
    });
  }
  renderCompareNote();
  const { svg } = renderPolarPlot(traces, { title: `DBB ${item.test_id || ''}`.trim() });
  $('#polar-plot').replaceChildren(svg);
  const dirs = traces.map((t) => t.direction);
  const note = $('#plot-note');
  if (dirs.length === 1) {
    const other = dirs[0] === 'ccw' ? 'CW' : 'CCW';
    note.textContent = `Only ${formatDirection(dirs[0])} is shown for this test; upload the ${other} file with the same test_id to overlay both directions.`;
  } else {
    note.textContent = 'Radial error about the least-squares circle, magnified around the nominal circle (thick grey).';
  }
  $('#plot-png-button').hidden = false;
  $('#plot-save-png').hidden = false;
}

function renderCompareNote() {
  const note = $('#compare-note');
  $('#compare-form').hidden = !shownDbb;
  $('#compare-clear').hidden = !overlay;
  if (!overlay) {
    note.hidden = true;
    note.replaceChildren();
    return;
  }
  const o = overlay;
  const key = typeof o.results?.circularity_um === 'number' ? `, circularity ${formatNumber(o.results.circularity_um, 'circularity_um')} µm` : '';
  note.hidden = false;
  note.dataset.measurementId = String(o.item.id);
  note.replaceChildren(`Overlaid at the same scale (dotted grey): ${describeFile(o)}, test ${o.item.test_id || '—'} of ${o.item.machine_id}${key}.`);
}

async function onCompare(event) {
  event.preventDefault();
  const text = $('#compare-id').value.trim().replace(/^#/, '');
  const id = Number(text);
  const note = $('#compare-note');
  if (!/^\d+$/.test(text) || !id) {
    note.hidden = false;
    note.replaceChildren(errorBox({ title: 'Not a measurement id', detail: `“${$('#compare-id').value}”: give the number of a stored DBB test, e.g. 48.` }));
    return;
  }
  try {
    const f = await fetchDbbFile(id);
    if (f.item.kind !== 'dbb') throw new Error(`measurement #${id} is a ${f.item.kind} measurement, not a DBB test`);
    overlay = f;
    if (shownDbb) renderDbbPlot(shownDbb.item, shownDbb.fetched);
  } catch (err) {
    if (handleAuth(err)) return;
    note.hidden = false;
    note.replaceChildren(errorBox(err));
  }
}

// Test conditions of each file: from its header (feed, radius, arc, sample rate, temperature,
// bar length, …) and the measurement and upload times.
const CONDITION_KEYS = [
  ['feed_mm_min', 'Feed', 'mm/min'],
  ['radius_mm', 'Radius', 'mm'],
  ['bar_length_mm', 'Bar length', 'mm'],
  ['arc_deg', 'Arc', '°'],
  ['sample_rate_hz', 'Sample rate', 'Hz'],
  ['temperature_c', 'Temperature', '°C'],
  ['plane', 'Plane', ''],
  ['centre_mm', 'Centre', 'mm'],
  ['tool_length_mm', 'Tool length', 'mm'],
  ['operator', 'Operator', ''],
];

function renderConditions(files) {
  const box = $('#conditions');
  const rows = [];
  for (const [key, label, unit] of CONDITION_KEYS) {
    if (!files.some((f) => f.metadata && f.metadata[key] !== undefined)) continue;
    rows.push([label, unit, ...files.map((f) => (f.metadata && f.metadata[key] !== undefined ? String(f.metadata[key]) : '—')), key]);
  }
  rows.push(['Measured at', '', ...files.map((f) => (f.item.timestamp ? formatTimestamp(f.item.timestamp) : 'not in the file')), 'measured_at']);
  rows.push(['Uploaded at', '', ...files.map((f) => formatTimestamp(f.item.uploaded_at)), 'uploaded_at']);
  box.replaceChildren(
    h(
      'table',
      { class: 'figures small conditions', 'data-testid': 'conditions-table' },
      h('caption', {}, 'Test conditions'),
      h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Condition'), h('th', { scope: 'col', class: 'unit' }, 'Unit'), ...files.map((f) => h('th', { scope: 'col', class: 'num' }, `${f.item.direction ? formatDirection(f.item.direction) : 'Value'} #${f.item.id}`)))),
      h('tbody', {}, ...rows.map((r) => h('tr', { 'data-key': r[r.length - 1] }, h('th', { scope: 'row' }, r[0]), h('td', { class: 'unit' }, r[1]), ...r.slice(2, -1).map((v) => h('td', { class: 'text' }, v))))),
    ),
  );
}

// ---------------------------------------------------------------- PNG plot, print, trace CSV

async function openPlotPng() {
  const id = state.measurementId;
  const button = $('#plot-png-button');
  if (!id) return;
  button.disabled = true;
  try {
    const svg = $('#polar-plot svg.polar');
    const blob = await api.plotPng(id, svg ? { umPerDiv: Number(svg.dataset.umPerDiv), divisions: Number(svg.dataset.divisions) } : null);
    if (state.pngUrl) URL.revokeObjectURL(state.pngUrl);
    state.pngUrl = URL.createObjectURL(blob);
    const img = $('#png-image');
    img.src = state.pngUrl;
    img.dataset.measurementId = id;
    $('#png-download').href = state.pngUrl;
    $('#png-download').download = `kinemetric-${id}-polar.png`;
    $('#png-dialog').showModal();
    $('#png-close').focus();
  } catch (err) {
    if (!handleAuth(err)) $('#plot-note').replaceChildren(errorBox(err));
  } finally {
    button.disabled = false;
  }
}

// The plot as shown (same scale, overlay included) as a PNG with the key figures under it: the
// SVG with its computed styles written into it, drawn on a canvas (blob: images are allowed).
const STYLE_PROPS = ['fill', 'stroke', 'stroke-width', 'stroke-dasharray', 'stroke-linejoin', 'paint-order', 'font-family', 'font-size', 'font-weight', 'text-anchor', 'opacity'];

function inlineStyles(source, copy) {
  const from = [source, ...source.querySelectorAll('*')];
  const to = [copy, ...copy.querySelectorAll('*')];
  from.forEach((node, i) => {
    // As presentation attributes (the page's Content-Security-Policy refuses style attributes).
    const cs = getComputedStyle(node);
    for (const p of STYLE_PROPS) {
      const v = cs.getPropertyValue(p);
      if (v) to[i].setAttribute(p, v);
    }
  });
}

function keyFigureLines() {
  const lines = [];
  for (const th of document.querySelectorAll('[data-testid="figures-table"] thead th[data-direction]')) {
    const dir = th.dataset.direction;
    const id = th.querySelector('.col-id')?.textContent.trim() || '';
    const cell = (key) => document.querySelector(`[data-testid="figures-table"] td[data-key="${key}"][data-direction="${dir}"]`)?.textContent || '—';
    lines.push(`${formatDirection(dir)} ${id}: circularity ${cell('circularity_um')} µm, centre offset ${cell('centre_offset_x_um')}, ${cell('centre_offset_y_um')} µm`);
  }
  for (const [key, label] of [['circular_hysteresis_um', 'Circular hysteresis H (common centre)'], ['circular_hysteresis_own_centres_um', 'H about each trace’s own centre'], ['bidirectional_circular_deviation_um', 'Bidirectional circular deviation G(b)']]) {
    const td = document.querySelector(`[data-testid="pair-${key}"]`);
    if (td) lines.push(`${label}: ${td.textContent} µm`);
  }
  const overlayNote = $('#compare-note');
  if (!overlayNote.hidden && overlayNote.textContent) lines.push(overlayNote.textContent);
  return lines;
}

async function savePlotPng() {
  const svg = $('#polar-plot svg.polar');
  if (!svg) return;
  const copy = svg.cloneNode(true);
  inlineStyles(svg, copy);
  // A margin round the drawing, so that no label at its edge ("180°") is cut off.
  const [x0, y0, w0, h0] = svg.getAttribute('viewBox').split(/\s+/).map(Number);
  const margin = 0.08 * w0;
  copy.setAttribute('viewBox', `${x0 - margin} ${y0 - margin} ${w0 + 2 * margin} ${h0 + 2 * margin}`);
  const W = 900;
  const plotH = 900;
  const lines = [$('#detail-heading').textContent, ...keyFigureLines()];
  const lineH = 26;
  const canvas = document.createElement('canvas');
  canvas.width = W;
  canvas.height = plotH + 20 + lines.length * lineH;
  const g = canvas.getContext('2d');
  g.fillStyle = '#fff';
  g.fillRect(0, 0, canvas.width, canvas.height);
  copy.setAttribute('width', String(W));
  copy.setAttribute('height', String(plotH));
  const url = URL.createObjectURL(new Blob([new XMLSerializer().serializeToString(copy)], { type: 'image/svg+xml' }));
  try {
    const img = new Image();
    await new Promise((res, rej) => {
      img.onload = res;
      img.onerror = () => rej(new Error('the plot could not be drawn'));
      img.src = url;
    });
    g.drawImage(img, 0, 0, W, plotH);
  } finally {
    URL.revokeObjectURL(url);
  }
  g.fillStyle = '#14202b';
  g.font = '18px sans-serif';
  lines.forEach((t, i) => g.fillText(t, 16, plotH + 10 + (i + 0.8) * lineH, W - 32));
  const blob = await new Promise((res) => canvas.toBlob(res, 'image/png'));
  const a = h('a', { href: URL.createObjectURL(blob), download: `kinemetric-${state.measurementId}-plot.png`, hidden: true });
  document.body.append(a);
  a.click();
  a.remove();
  $('#plot-save-png').dataset.lines = String(lines.length);
}

async function exportTrace() {
  const id = state.measurementId;
  if (!id) return;
  const m = await api.measurement(id);
  const cols = Object.keys(m.samples || {});
  const n = cols.length ? m.samples[cols[0]].length : 0;
  const rows = [cols];
  for (let i = 0; i < n; ++i) rows.push(cols.map((c) => m.samples[c][i]));
  downloadText(toCsv(rows), `kinemetric-${id}-samples.csv`, 'text/csv');
}

export function initDetail() {
  $('#plot-png-button').addEventListener('click', openPlotPng);
  // A new tolerance table judges the shown measurement again.
  window.addEventListener('km-tolerances-changed', (e) => {
    if (state.measurementId && e.detail?.machineId === state.machineId) showMeasurement(state.measurementId);
  });
  // Focus returns to the button that opened the dialog when it closes.
  $('#png-dialog').addEventListener('close', () => $('#plot-png-button').focus());
  $('#png-close').addEventListener('click', () => $('#png-dialog').close());
  $('#png-dialog').addEventListener('click', (e) => {
    if (e.target === e.currentTarget) $('#png-dialog').close(); // click on the backdrop
  });
  $('#print-report').addEventListener('click', () => window.print());
  $('#plot-save-png').addEventListener('click', () =>
    savePlotPng().catch((err) => $('#plot-note').replaceChildren(errorBox(err))),
  );
  $('#trace-csv').addEventListener('click', () => exportTrace().catch((err) => handleAuth(err)));
  $('#compare-form').addEventListener('submit', onCompare);
  $('#compare-clear').addEventListener('click', () => {
    overlay = null;
    $('#compare-id').value = '';
    if (shownDbb) renderDbbPlot(shownDbb.item, shownDbb.fetched);
  });
}
