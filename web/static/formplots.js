// Plots of form measurements (straightness and parallelism profiles, flatness colour map), of a
// laser-tracker survey (volumetric error vectors, error components) and of a rotary-axis R-test
// (location errors with σ, what the poses do not determine, displacement per pose before and
// after the fit; docs/formats.md §3.18).

import { axesGrid, el, r2, renderColourMap, renderProfilePlot, ticks } from './charts.js';
import { renderComponentCharts } from './components.js';
import { $, h } from './dom.js';
import { formatNumber } from './format.js';
import { renderTrackerVectorPlot } from './tracker.js';

// The set-up of a form measurement from its header (docs/formats.md §1.3–1.5) and result:
// the travel axis, the direction of the error, the sensor, the artefact read, the reference of
// the figures. A flatness grid has no axis: its plane is XY, its error Z (columns x, y, z).
const words = (v) => (v === undefined || v === null || v === '' ? null : String(v).replace(/_/g, ' '));

export function formSetup(item, meta, results) {
  const m = { ...(results?.measurement || {}), ...meta };
  const flat = item.kind === 'flatness';
  const reversal = m.reversal ? `set-up ${m.reversal} of pair “${m.pair_id || ''}”${m.reversal_setup === 'artefact_and_sensor' ? ' (artefact and sensor turned over)' : ''}` : null;
  const rows = [
    ['axis', flat ? 'Plane' : 'Axis (travel)', flat ? 'XY' : words(m.axis)],
    ['error_direction', 'Error direction', flat ? 'Z (height)' : words(m.error_direction)],
    ['sensor', 'Sensor', words(m.sensor) || 'not stated in the file'],
    ['reference', 'Reference (artefact read)', words(m.reference ?? m.artefact) || (m.datum ? `the ${words(m.datum)}` : 'not stated in the file')],
    ['datum', 'Datum', flat || item.kind === 'parallelism' ? words(m.datum) || 'not stated in the file' : null],
    ['figures_reference', 'Figures about', words(results?.reference)],
    ['reversal', 'Reversal', reversal],
  ].filter((r) => r[2]);
  return h(
    'table',
    { class: 'figures small form-setup', 'data-testid': 'form-setup' },
    h('caption', {}, 'Set-up'),
    h('tbody', {}, ...rows.map(([key, label, v]) => h('tr', { 'data-key': key }, h('th', { scope: 'row' }, label), h('td', { class: 'text' }, v)))),
  );
}

function sampleColumns(f) {
  const s = f?.measurement?.samples || {};
  return s;
}

export function renderFormPlot(item, f) {
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

export function renderTrackerPlot(item, f) {
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
  const title = `Volumetric error of ${item.machine_id || ''}`.trim();
  // One Z layer at a time (or all): points of other layers hide one another in the XY view.
  const layers = [...new Set(points.map((p) => p[2]))].sort((a, b) => a - b);
  const plotBox = h('div', { class: 'tracker-plot', 'data-testid': 'tracker-plot' });
  const draw = (layer) => {
    const keep = points.map((p) => layer === 'all' || p[2] === Number(layer));
    const { svg } = renderTrackerVectorPlot(
      points.filter((_, i) => keep[i]),
      errors.filter((_, i) => keep[i]),
      { title: layer === 'all' ? title : `${title}, layer Z = ${formatNumber(Number(layer), '_mm')} mm` },
    );
    svg.dataset.layer = String(layer);
    plotBox.replaceChildren(svg);
  };
  const parts = [];
  if (layers.length > 1) {
    const select = h(
      'select',
      { id: 'tracker-layer', 'data-testid': 'tracker-layer', onchange: (e) => draw(e.target.value) },
      h('option', { value: 'all' }, `all ${layers.length} layers`),
      ...layers.map((z) => h('option', { value: String(z) }, `Z = ${formatNumber(z, '_mm')} mm`)),
    );
    parts.push(h('p', { class: 'tracker-layers no-print' }, h('label', { for: 'tracker-layer' }, 'Layer '), select));
  }
  draw('all');
  container.replaceChildren(...parts, plotBox);
  if (r.decomposition && typeof r.decomposition === 'object') container.append(renderComponentCharts(r.decomposition));
  const dropped = errors.filter((e) => !e).length;
  note.textContent =
    'Volumetric error at each commanded point (arrow, magnified) after the best-fit placement of the machine frame' +
    (dropped ? `; ${dropped} point${dropped === 1 ? '' : 's'} dropped (hollow).` : '.');
}

// ---------------------------------------------------------------- rotary axes (R-test)

// ISO 230-1's order: the tilt axis (A of an AC table, B of a BC one), then C.
const ROTARY_ERRORS = [
  ['YOA_um', 'position of the A axis line in Y'],
  ['ZOA_um', 'position of the A axis line in Z'],
  ['BOA_urad', 'orientation of the A axis line about Y'],
  ['COA_urad', 'orientation of the A axis line about Z'],
  ['XOB_um', 'position of the B axis line in X'],
  ['ZOB_um', 'position of the B axis line in Z'],
  ['AOB_urad', 'orientation of the B axis line about X'],
  ['COB_urad', 'orientation of the B axis line about Z'],
  ['XOC_um', 'position of the C axis line in X'],
  ['YOC_um', 'position of the C axis line in Y'],
  ['AOC_urad', 'orientation of the C axis line about X'],
  ['BOC_urad', 'orientation of the C axis line about Y'],
];
const fixed = (v, d) => (typeof v === 'number' && Number.isFinite(v) ? v.toFixed(d).replace('-', '−') : '—');
const norm3 = (v) => (Array.isArray(v) && v.length === 3 ? Math.hypot(v[0], v[1], v[2]) : NaN);

function rotaryErrorTable(r) {
  const rows = ROTARY_ERRORS.filter(([key]) => r.location_errors?.[key]).map(([key, what]) => {
    const e = r.location_errors[key];
    const name = key.slice(0, key.indexOf('_'));
    const unit = key.endsWith('_urad') ? 'µrad' : 'µm';
    const known = e.identifiable && typeof e.value === 'number';
    return h(
      'tr',
      { 'data-error': name, class: known ? '' : 'not-determined' },
      h('th', { scope: 'row' }, `${name} `, h('span', { class: 'muted' }, what)),
      h('td', { class: 'num' }, known ? fixed(e.value, 2) : 'not determined'),
      h('td', { class: 'num' }, known ? `± ${fixed(e.sigma, 2)}` : '—'),
      h('td', { class: 'unit' }, unit),
    );
  });
  return h(
    'table',
    { class: 'figures small', 'data-testid': 'rotary-errors' },
    h('caption', {}, `Location errors (ISO 230-1), ${r.kinematics || 'trunnion'} table`),
    h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Error'), h('th', { scope: 'col', class: 'num' }, 'Value'), h('th', { scope: 'col', class: 'num' }, 'σ'), h('th', { scope: 'col', class: 'unit' }, 'Unit'))),
    h('tbody', {}, ...rows),
  );
}

// The length of the sphere's displacement at each pose, measured (before) and residual (after).
function rotaryPoseChart(poses) {
  const W = 900, H = 320, L = 64, R = 16, T = 36, B = 52;
  const measured = poses.map((p) => norm3(p.measured_um));
  const residual = poses.map((p) => norm3(p.residual_um));
  const ymax = Math.max(1e-3, ...measured.filter(Number.isFinite), ...residual.filter(Number.isFinite)) * 1.08;
  const n = Math.max(poses.length, 2);
  const px = (i) => L + (i / (n - 1)) * (W - L - R);
  const py = (v) => T + (1 - v / ymax) * (H - T - B);
  const svg = el('svg', { viewBox: `0 0 ${W} ${H}`, role: 'img', class: 'chart rotary-poses', 'data-testid': 'rotary-pose-chart', 'aria-label': `Displacement per pose: measured and residual after the fit, ${poses.length} poses.` });
  svg.append(el('title', {}, 'Displacement per pose, measured and after the fit'));
  const xt = ticks(1, n, 8);
  svg.append(axesGrid({ W, H, L, R, T, B, px: (v) => px(v - 1), py, xt, yt: ticks(0, ymax, 5) }));
  const series = [
    ['measured', measured, '#1f5fa8'],
    ['residual (measured − model)', residual, '#c0392b'],
  ];
  series.forEach(([label, ys, colour], k) => {
    const pts = ys.map((y, i) => (Number.isFinite(y) ? `${r2(px(i))},${r2(py(y))}` : null)).filter(Boolean);
    svg.append(el('polyline', { points: pts.join(' '), fill: 'none', stroke: colour, 'stroke-width': 2, 'data-series': k === 0 ? 'measured' : 'residual' }));
    svg.append(el('rect', { x: L + 8 + k * 240, y: 10, width: 14, height: 14, fill: colour }));
    svg.append(el('text', { x: L + 28 + k * 240, y: 17, dy: '0.35em', class: 'legend' }, label));
  });
  svg.append(el('text', { x: (L + W - R) / 2, y: H - 12, 'text-anchor': 'middle', class: 'axis-title' }, 'Pose (file order)'));
  svg.append(el('text', { x: 16, y: (T + H - B) / 2, transform: `rotate(-90 16 ${(T + H - B) / 2})`, 'text-anchor': 'middle', class: 'axis-title' }, 'Length (µm)'));
  return h('figure', { class: 'chart-box' }, svg, h('figcaption', {}, 'Length of the displacement at each pose: measured, and what the fitted location errors leave (the residual).'));
}

function rotaryPoseTable(r) {
  const tilt = r.kinematics === 'BC-trunnion' ? 'B' : 'A';
  const c3 = (v) => (Array.isArray(v) ? v.map((x) => h('td', { class: 'num' }, fixed(x, 2))) : [h('td'), h('td'), h('td')]);
  const head = ['Pose', `${tilt} (°)`, 'C (°)', 'dx', 'dy', 'dz', 'dx after', 'dy after', 'dz after'];
  return h(
    'details',
    { class: 'rotary-poses-table' },
    h('summary', {}, `Displacement per pose, measured and after the fit (µm, ${(r.residuals || []).length} poses)`),
    h(
      'div',
      { class: 'table-scroll' },
      h(
        'table',
        { class: 'figures small', 'data-testid': 'rotary-poses' },
        h('thead', {}, h('tr', {}, ...head.map((t) => h('th', { scope: 'col', class: 'num' }, t)))),
        h('tbody', {}, ...(r.residuals || []).map((p, i) => h('tr', {}, h('td', { class: 'num' }, String(i + 1)), h('td', { class: 'num' }, fixed(p.a_deg ?? p.b_deg, 1)), h('td', { class: 'num' }, fixed(p.c_deg, 1)), ...c3(p.measured_um), ...c3(p.residual_um)))),
      ),
    ),
  );
}

export function renderRotaryView(item, f) {
  const container = $('#polar-plot');
  const r = f?.results || {};
  if (!r.location_errors) {
    container.replaceChildren(h('p', { class: 'placeholder' }, 'No location errors for this measurement.'));
    $('#plot-note').textContent = '';
    return;
  }
  const sentences = (r.not_separable || []).map((g) => h('p', { class: 'note' }, `${g.sentence}.`));
  container.replaceChildren(
    h(
      'div',
      { class: 'rotary-view', 'data-testid': 'rotary-view' },
      h('div', { class: 'table-scroll' }, rotaryErrorTable(r)),
      h('p', { 'data-testid': 'rotary-rank' }, `Rank of the pose set ${r.rank} of ${r.parameters}, condition ${r.condition === null ? '—' : fixed(r.condition, 1)}; RMS ${fixed(r.measured_rms_um, 3)} µm before the fit, ${fixed(r.residual_rms_um, 3)} µm after.`),
      ...sentences,
      rotaryPoseChart(r.residuals || []),
      rotaryPoseTable(r),
    ),
  );
  $('#plot-note').textContent = `R-test of ${item.test_id || 'the rotary axes'}: ${formatNumber(r.poses)} poses, the sphere at (${(r.sphere_mm || []).map((v) => fixed(v, 1)).join(', ')}) mm.`;
}
