// The figures table of a measurement (one column per file of a DBB pair), the pair's ISO 230-4
// figures, and the tables of arrays in the results (periodic components, decomposition, …).

import { $, downloadText, h, toCsv } from './dom.js';
import { formatDirection, formatMode, formatNumber, formatTimestamp, formatUncertainty, fullLabelOf, labelOf, unitOf } from './format.js';

export const LEAD_ROWS = ['test_id', 'direction', 'mode', 'centre_offset_x_um', 'centre_offset_y_um', 'average_radial_error_um', 'circularity_um'];

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
  positioning: [
    'axis',
    'accuracy_um',
    'reversal_value_um',
    'systematic_deviation_um',
    'mean_deviation_range_um',
    'repeatability_um',
    'accuracy_up_um',
    'accuracy_down_um',
    'repeatability_up_um',
    'repeatability_down_um',
    'systematic_deviation_up_um',
    'systematic_deviation_down_um',
    'mean_reversal_value_um',
    'iso230_2_compliant',
    'runs',
    'target_count',
  ],
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
  positioning: 'Positioning figures (ISO 230-2)',
};

// Arrays drawn as charts / tables of their own rather than as rows of the figures table.
const OWN_VIEWS = new Set(['harmonics', 'diagnosis', 'not_identifiable', 'periodic', 'references', 'measurement', 'decomposition', 'transform', 'point_ids', 'targets', 'compensation', 'uncertainty', 'instrument']);

// Objects of a kind's results shown in a block of their own (the conditions of a positioning
// test: air and material, positioning.js), not as rows of the figures table.
const OWN_BLOCKS = { positioning: new Set(['air', 'material', 'warnings']) };

// Bookkeeping of the analysis rather than figures of the machine: not rows of the table (the
// evaluated arc is a row once, at the top level; the versions stay in the JSON and CSV).
const INTERNAL = new Set(['analysis_version', 'iso230_4.evaluated_arc_deg', 'iso230_4.deviation_units', 'iso230_4.radial_reference', 'iso230_4.evaluated_over']);

// Flattens one results object into {key: value} rows; arrays of objects are returned apart.
function flattenResults(results, kind) {
  const flat = {};
  const tables = {};
  for (const [key, value] of Object.entries(results || {})) {
    if (OWN_VIEWS.has(key) || INTERNAL.has(key) || OWN_BLOCKS[kind]?.has(key)) continue;
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
        if (typeof v2 === 'number' && !INTERNAL.has(`${key}.${k2}`)) flat[`${key}.${k2}`] = v2;
      }
    }
  }
  return { flat, tables };
}

function cellText(key, value) {
  if (value === undefined || value === null) return '—';
  if (key === 'direction') return formatDirection(value);
  if (key === 'mode') return formatMode(value);
  if (typeof value === 'boolean') return value ? 'yes' : 'no';
  if (key === 'timestamp') return formatTimestamp(value);
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

// The expanded uncertainty of a row's figure in an `uncertainty` object (docs/formats.md §3.17):
// the figure by its key, else by its last part ("iso230_4.circular_deviation_um").
function uncertaintyOf(uncertainty, key) {
  const figures = uncertainty?.figures || {};
  const f = figures[key] || figures[key.split('.').pop()];
  return f && typeof f.U_um === 'number' ? f : null;
}

// " ± U" beside a value, its title naming k and the method.
function uSpan(uncertainty, key) {
  const f = uncertaintyOf(uncertainty, key);
  if (!f) return '';
  return h('span', { class: 'figure-u', 'data-testid': 'figure-u', title: `expanded uncertainty U (k = ${f.k ?? 2}), ${uncertainty.method || ''}; 95 % interval ${formatNumber(f.interval_um?.[0], key)} to ${formatNumber(f.interval_um?.[1], key)}` }, ` ± ${formatUncertainty(f.U_um)}`);
}

// The uncertainty budget of each column, folded: the method, the inputs (stated and not) and the
// contribution of each stated input to each figure.
function uncertaintyBudget(columns) {
  const blocks = [];
  for (const c of columns) {
    const u = c.uncertainty;
    if (!u) continue;
    const figures = Object.entries(u.figures || {});
    const stated = (u.inputs || []).filter((i) => i.stated);
    const who = c.item.direction ? ` — ${formatDirection(c.item.direction)}` : '';
    const head = figures.length ? `${u.method}, ${u.draws} draws, seed ${u.seed}, U = k·u with k = ${u.k}` : 'No input uncertainty stated in the file: the figures carry no U.';
    blocks.push(
      h(
        'details',
        { class: 'uncertainty-budget', 'data-testid': 'uncertainty-budget', 'data-direction': c.item.direction || '' },
        h('summary', {}, `Uncertainty budget${who}`),
        h('p', { class: 'note' }, head),
        h('p', { class: 'note' }, `Stated: ${stated.map((i) => `${i.input} ${i.u} ${i.unit}`).join(', ') || 'none'}. Not stated (taken as 0): ${(u.not_stated || []).join(', ') || 'none'}.`),
        ...(u.warnings || []).map((w) => h('p', { class: 'note warn' }, w)),
        figures.length
          ? h(
              'table',
              { class: 'figures small' },
              h('thead', {}, h('tr', {}, h('th', {}, 'Figure'), h('th', { class: 'num' }, 'U (µm)'), h('th', { class: 'num' }, '95 % interval (µm)'), ...stated.map((i) => h('th', { class: 'num' }, `${i.input} (µm)`)))),
              h(
                'tbody',
                {},
                ...figures.map(([key, f]) =>
                  h(
                    'tr',
                    { 'data-key': key },
                    h('th', { scope: 'row' }, rowLabel(key)),
                    h('td', { class: 'num' }, formatUncertainty(f.U_um)),
                    h('td', { class: 'num' }, `${formatNumber(f.interval_um?.[0], key)} to ${formatNumber(f.interval_um?.[1], key)}`),
                    ...stated.map((i) => h('td', { class: 'num' }, formatUncertainty((f.budget || []).find((b) => b.input === i.input)?.contribution_um))),
                  ),
                ),
              ),
            )
          : '',
      ),
    );
  }
  return blocks;
}

export function renderFigures(fetched, { kind = 'dbb', pair = null } = {}) {
  const columns = fetched.map((f) => ({ item: f.item, uncertainty: f.results?.uncertainty || null, ...flattenResults(f.results, kind) }));
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
            numeric ? uSpan(c.uncertainty, key) : '',
          ),
        ),
      ),
    );
  }
  // CW + CCW figures of the pair (ISO 230-4): one value for both directions.
  if (pair && pair.pair) {
    const rows = ['circular_hysteresis_um', 'circular_hysteresis_own_centres_um', 'bidirectional_circular_deviation_um'].filter((k) => typeof pair.pair[k] === 'number');
    const firstLeadRow = [...tbody.children].findIndex((tr) => !tr.classList.contains('lead') && !KIND_ROWS.dbb.includes(tr.dataset.key));
    const anchor = firstLeadRow >= 0 ? tbody.children[firstLeadRow] : null;
    for (const k of rows) {
      tbody.insertBefore(
        h(
          'tr',
          { 'data-key': `pair.${k}`, class: 'lead pair-row' },
          h('th', { scope: 'row' }, labelOf(k)),
          h('td', { class: 'unit' }, unitOf(k).unit),
          h('td', { class: 'num', colspan: columns.length, 'data-key': `pair.${k}`, 'data-testid': `pair-${k}` }, formatNumber(pair.pair[k], k), uSpan(pair.pair.uncertainty, k)),
        ),
        anchor,
      );
    }
  }
  const table = h('table', { class: 'figures', 'data-testid': 'figures-table', 'data-kind': kind }, h('caption', {}, CAPTIONS[kind] || 'Figures'), thead, tbody);
  // A table wider than its column (both directions on a phone) scrolls with a visible hint.
  const box = h('div', { class: 'table-scroll' }, table);
  $('#figures').replaceChildren(box);
  box.after(csvButton(columns, keys), ...uncertaintyBudget(columns));
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
          h('td', { class: 'num', 'data-key': 'sigma' }, `± ${formatUncertainty(r.s)}`),
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

function labelWithUnit(key) {
  const { unit } = unitOf(key);
  return unit ? `${labelOf(key)} (${unit})` : labelOf(key);
}


// CSV of the figures table: quantity, unit, one column per file.
function csvButton(columns, keys) {
  const rows = [['quantity', 'key', 'unit', ...columns.map((c) => `${c.item.direction || 'value'} #${c.item.id}`)]];
  for (const key of keys) {
    if (columns.every((c) => c.flat[key] === undefined)) continue;
    rows.push([rowLabel(key), key, unitOf(key.split('.').pop()).unit, ...columns.map((c) => (Array.isArray(c.flat[key]) ? c.flat[key].join(' ') : c.flat[key]))]);
  }
  const id = columns[0]?.item.id;
  return h(
    'button',
    { type: 'button', class: 'secondary small no-print', 'data-testid': 'figures-csv', onclick: () => downloadText(toCsv(rows), `kinemetric-${id}-figures.csv`, 'text/csv') },
    'Figures as CSV',
  );
}
