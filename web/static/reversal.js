// The straightness reversal of a pair of set-ups (GET /api/v1/measurements/{id}/reversal): the
// machine's straightness and the artefact's form separated by reversal, drawn as two curves over
// the position, with their least-squares straightness. Shown under the profile of either set-up;
// the view carries data-reversal-partner with the other set-up's id.

import { api, ApiError } from './api.js';
import { axesGrid, chartWidth, ticks } from './charts.js';
import { $, el, h, r2 } from './dom.js';
import { formatNumber } from './format.js';
import { measurementHash } from './router.js';

const SERIES = [
  ['machine_um', 'Machine (straightness of the axis)', 'machine'],
  ['artefact_um', 'Artefact (form of the straightedge)', 'artefact'],
];

export function renderReversalChart(rev, W = 900) {
  const x = rev.positions_mm || [];
  const narrow = W < 600;
  const H = 320;
  const L = 70;
  const R = 16;
  const T = narrow ? 44 : 36;
  const B = 52;
  const all = SERIES.flatMap(([k]) => rev[k] || []);
  const pad = (Math.max(...all) - Math.min(...all)) * 0.08 || 0.5;
  const ylo = Math.min(...all) - pad;
  const yhi = Math.max(...all) + pad;
  const xmin = Math.min(...x);
  const xmax = Math.max(...x);
  const px = (v) => L + ((v - xmin) / (xmax - xmin || 1)) * (W - L - R);
  const py = (v) => T + (1 - (v - ylo) / (yhi - ylo || 1)) * (H - T - B);
  const svg = el('svg', { viewBox: `0 0 ${W} ${H}`, width: W, height: H, role: 'img', class: 'chart profile reversal', 'data-testid': 'reversal-plot', 'aria-label': 'Machine and artefact curves separated by reversal' });
  svg.append(el('title', {}, 'Straightness reversal: machine and artefact'));
  svg.append(axesGrid({ W, H, L, R, T, B, px, py, xt: ticks(xmin, xmax, 8), yt: ticks(ylo, yhi, 6) }));
  svg.append(el('text', { x: r2((L + W - R) / 2), y: H - 10, 'text-anchor': 'middle', class: 'axis-title' }, 'Position (mm)'));
  const my = r2((T + H - B) / 2);
  svg.append(el('text', { x: 16, y: my, 'text-anchor': 'middle', class: 'axis-title', transform: `rotate(-90 16 ${my})` }, 'Deviation (µm)'));
  SERIES.forEach(([key, label, cls], i) => {
    const y = rev[key] || [];
    svg.append(el('path', { d: y.map((v, k) => `${k ? 'L' : 'M'}${r2(px(x[k]))},${r2(py(v))}`).join(''), class: `reversal-line ${cls}`, 'data-testid': `reversal-${cls}`, 'data-points': y.length }));
    const lg = el('g', { transform: narrow ? `translate(${L + 8} ${10 + i * 14})` : `translate(${L + 8 + i * 300} 16)` });
    lg.append(el('line', { x1: 0, x2: 18, y1: 0, y2: 0, class: `reversal-line ${cls}` }));
    lg.append(el('text', { x: 24, y: 0, dy: '0.35em', class: 'tick' }, label));
    svg.append(lg);
  });
  return svg;
}

// Draws the reversal of a straightness set-up into #reversal-box, or nothing when the profile is
// not one set-up of a pair (or its partner is not stored). isCurrent() tells whether the view
// still shows this measurement.
export async function showReversal(item, measurement, isCurrent) {
  const box = $('#reversal-box');
  box.replaceChildren();
  box.hidden = true;
  if (item.kind !== 'straightness' || !measurement?.metadata?.reversal) return;
  let out = null;
  // Asked only when the measurement names the other set-up (partner_id null: not stored).
  if (measurement.partner_id !== null) {
    try {
      out = await api.reversal(item.id);
    } catch (err) {
      if (!(err instanceof ApiError) || err.status !== 404) throw err;
    }
  }
  if (!isCurrent()) return;
  if (!out || !out.reversal) {
    box.replaceChildren(h('p', { class: 'note', 'data-testid': 'reversal-missing' }, `Set-up ${String(measurement.metadata.reversal)} of reversal pair “${measurement.metadata.pair_id || ''}”: the other set-up is not stored yet, so machine and artefact cannot be separated.`));
    box.hidden = false;
    return;
  }
  const rev = out.reversal;
  $('#detail').dataset.reversalPartner = String(out.partner_id);
  box.replaceChildren(
    h('h3', {}, 'Reversal: machine and artefact'),
    h('p', { class: 'note', 'data-testid': 'reversal-note' }, `With set-up ${measurement.metadata.reversal === 'a' ? 'b' : 'a'} `, h('a', { href: measurementHash(out.partner_id), 'data-testid': 'reversal-partner-link' }, `#${out.partner_id}`), ` of pair “${rev.pair_id || measurement.metadata.pair_id || ''}” (${rev.reversal_setup === 'artefact_and_sensor' ? 'artefact and sensor turned over' : 'artefact turned over'}): the machine’s straightness ${formatNumber(rev.machine_straightness_lsq_um, '_um')} µm and the artefact’s ${formatNumber(rev.artefact_straightness_lsq_um, '_um')} µm (least squares).`),
    h('figure', { class: 'chart-box chart-scroll' }, renderReversalChart(rev, chartWidth($('#detail')))),
  );
  box.hidden = false;
}

export function resetReversal() {
  $('#reversal-box').replaceChildren();
  $('#reversal-box').hidden = true;
  delete $('#detail').dataset.reversalPartner;
}
