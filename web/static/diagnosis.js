// The DBB diagnosis (which effects make up the circularity, from the pair the server's /pair
// uses when there is one) and the harmonics of the radial error.

import { renderContributionChart, renderHarmonicsChart } from './charts.js';
import { $, h } from './dom.js';
import { displayUnit, effectWords, formatDirection, formatNumber, formatUncertainty } from './format.js';

export function resetAnalysis() {
  $('#analysis').hidden = true;
  $('#diagnosis-table-box').replaceChildren();
  $('#contribution-chart').replaceChildren();
  $('#harmonics-chart').replaceChildren();
  $('#diagnosis-source').textContent = '';
  $('#not-identifiable').hidden = true;
  $('#not-identifiable').replaceChildren();
  $('#plot-png-button').hidden = true;
  $('#plot-save-png').hidden = true;
}

function valueText(v) {
  if (Array.isArray(v)) return v.map((x) => formatNumber(x, '_um')).join(', ');
  return formatNumber(v, '_um');
}

// A standard uncertainty with two significant digits ("± 0.00035", "± 1500"), never "± 0.000".
function uncertaintyText(v) {
  if (Array.isArray(v)) return v.map((x) => formatUncertainty(x)).join(', ');
  return formatUncertainty(v);
}

function shapeText(d) {
  const parts = [];
  if (typeof d.period_mm === 'number') parts.push(`period ${formatNumber(d.period_mm, '_um')} mm`);
  if (typeof d.width_deg === 'number') {
    // A reversal spike's width also in time: the decay constant of an exponential decay.
    const time = typeof d.width_s === 'number' ? ` = ${formatNumber(d.width_s)} s` : '';
    parts.push(`width ${formatNumber(d.width_deg, '_deg')}°${time}`);
  }
  if (d.spike_shape === 'exponential') parts.push('exponential decay');
  if (d.spike_shape === 'gaussian') parts.push('Gaussian-like decay');
  if (typeof d.period_deg === 'number') parts.push(`period ${formatNumber(d.period_deg, '_deg')}°`);
  return parts.join(', ');
}

export function renderAnalysis(item, fetched, pair, pairError) {
  resetAnalysis();
  if (item.kind !== 'dbb') return;
  $('#analysis').hidden = false;
  $('#plot-png-button').hidden = false;
  $('#plot-save-png').hidden = false;
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
          h('td', { class: 'num', 'data-key': 'uncertainty' }, `± ${uncertaintyText(d.uncertainty)}`),
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
