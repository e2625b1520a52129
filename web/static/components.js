// Geometric error components of a 3-axis machine along each of its axes, drawn from the
// decomposition of the laser-tracker volumetric error map (results.decomposition; model of
// analysis/tracker/volumetric_decomposition.h eq. (1), EvaluateDecomposition):
//
//   e(p) = τ + A·(p − p0) + Σ_a Σ_{k≥2} c_{a,k} P_k(t_a),   t_a = (a − a0)/h_a
//
// Along axis a (coordinate u ∈ [a0 − h_a, a0 + h_a]), in µm, τ and the best-fit rotation removed:
//   positioning   E_AA(u) = 1e-3·scale_a[ppm]·(u − a0) + Σ_k c_{a,a,k} P_k(t)
//   straightness  E_BA(u) = Σ_k c_{a,b,k} P_k(t)                        (b ≠ a, orders ≥ 2)
//   squareness    −½·S_ab[µm/m]·1e-3·(u − a0) in direction b: the model sets A_ab = A_ba = −S_ab/2,
//                 i.e. shares the squareness equally between the two axes of a plane. The linear
//                 straightness of one axis is not separable from the squareness and the rotation,
//                 so this share is a convention: drawn dashed, apart from the straightness curve.
// No ±1σ band: the per-term σ come from a covariance that couples the terms (through the
// tracker parameters, and the discrete Legendre columns are not orthogonal) and the covariance
// is not reported, so a band from the per-term σ alone would be wrong. σ are in the term table.

import { axesGrid, el, r2, ticks } from './charts.js';
import { formatNumber, formatUncertainty } from './format.js';

const AXES = ['x', 'y', 'z'];
const COLOUR = { x: '#b3261e', y: '#1b7f3b', z: '#1f5fbf' };
const SQUARENESS_PAIRS = { xy: ['x', 'y'], yz: ['y', 'z'], zx: ['z', 'x'] };
const SAMPLES = 101;

// Legendre polynomial P_k(t) by the three-term recurrence (same as km::tracker::LegendreP).
export function legendreP(k, t) {
  let p0 = 1;
  let p1 = t;
  if (k === 0) return p0;
  for (let n = 1; n < k; ++n) {
    const p2 = ((2 * n + 1) * t * p1 - n * p0) / (n + 1);
    p0 = p1;
    p1 = p2;
  }
  return p1;
}

const num = (v) => (typeof v === 'number' && Number.isFinite(v) ? v : 0);
const upper = (s) => String(s).toUpperCase();

// The component curves along each axis as functions of the axis coordinate (mm → µm).
// Returns [{axis, centre, half, lo, hi, curves: [{direction, kind, f}], shares: [{direction, pair, f}]}];
// axes that do not move in the map (half range 0) get curves = [].
export function componentModel(dec) {
  const terms = Array.isArray(dec?.terms) ? dec.terms : [];
  return AXES.map((a, i) => {
    const centre = num(dec?.centre_mm?.[i]);
    const half = num(dec?.half_range_mm?.[i]);
    const out = { axis: a, centre, half, lo: centre - half, hi: centre + half, curves: [], shares: [] };
    if (!(half > 0)) return out;
    const poly = (b) => {
      const own = terms.filter((t) => t.axis === a && t.direction === b && Number.isFinite(t.value_um));
      return (u) => own.reduce((s, t) => s + t.value_um * legendreP(t.order, (u - centre) / half), 0);
    };
    for (const b of AXES) {
      const p = poly(b);
      if (b === a) {
        const scale = num(dec?.scale_ppm?.[a]);
        out.curves.push({ direction: b, kind: 'positioning', f: (u) => 1e-3 * scale * (u - centre) + p(u) });
      } else {
        out.curves.push({ direction: b, kind: 'straightness', f: p });
      }
    }
    for (const [pair, [p, q]] of Object.entries(SQUARENESS_PAIRS)) {
      if (p !== a && q !== a) continue;
      if ((Array.isArray(dec?.fixed) ? dec.fixed : []).some((f) => String(f).startsWith(`squareness_${pair}`))) continue; // not identified
      const s = dec?.squareness_um_per_m?.[pair];
      if (typeof s !== 'number' || !Number.isFinite(s)) continue;
      out.shares.push({ direction: p === a ? q : p, pair, f: (u) => -0.5e-3 * s * (u - centre) });
    }
    return out;
  });
}

// "E" with a two-letter subscript (ISO 230-1 style: E_YX = straightness of X in Y).
function errorName(parent, direction, axis) {
  parent.append('E');
  parent.append(el('tspan', { 'baseline-shift': 'sub', 'font-size': '75%' }, `${upper(direction)}${upper(axis)}`));
  return parent;
}

function componentChart(m) {
  const W = 350;
  const H = 310;
  const L = 58;
  const R = 12;
  const T = 30;
  const B = 112; // x ticks + title + two-column legend
  const A = upper(m.axis);
  const us = Array.from({ length: SAMPLES }, (_, i) => m.lo + ((m.hi - m.lo) * i) / (SAMPLES - 1));
  const series = [
    ...m.curves.map((c) => ({ ...c, dashed: false, ys: us.map(c.f) })),
    ...m.shares.map((s) => ({ ...s, kind: 'squareness', dashed: true, ys: us.map(s.f) })),
  ];
  const all = [0, ...series.flatMap((s) => s.ys)];
  let ylo = Math.min(...all);
  let yhi = Math.max(...all);
  const pad = (yhi - ylo) * 0.08 || 0.5;
  ylo -= pad;
  yhi += pad;
  const xt = ticks(m.lo, m.hi, 5);
  const yt = ticks(ylo, yhi, 5);
  const px = (u) => L + ((u - m.lo) / (m.hi - m.lo)) * (W - L - R);
  const py = (v) => T + (1 - (v - ylo) / (yhi - ylo)) * (H - T - B);
  const title = `Geometric errors along ${A}`;
  const svg = el('svg', {
    viewBox: `0 0 ${W} ${H}`,
    width: W,
    height: H,
    role: 'img',
    class: 'chart components-chart',
    'data-testid': 'component-chart',
    'data-axis': m.axis,
    'data-lo-mm': m.lo,
    'data-hi-mm': m.hi,
    'data-px-per-um': (H - T - B) / (yhi - ylo),
    'data-zero-px': py(0),
    'aria-label':
      `${title}: ` +
      series
        .map((s) => `E${upper(s.direction)}${A} ${s.kind === 'squareness' ? `squareness ${upper(s.pair)} share` : s.kind} from ${s.ys[0].toFixed(3)} to ${s.ys[SAMPLES - 1].toFixed(3)} µm`)
        .join('; ') +
      ` over ${A} ${m.lo.toFixed(1)} to ${m.hi.toFixed(1)} mm.`,
  });
  svg.append(el('title', {}, title));
  svg.append(el('text', { x: L, y: 18, class: 'axis-title' }, `${A} axis`));
  const grid = axesGrid({ W, H, L, R, T, B, px, py, xt, yt, xTickGap: 17, yTickGap: 6 });
  grid.append(el('line', { x1: L, x2: W - R, y1: r2(py(0)), y2: r2(py(0)), class: 'axis components-zero', 'data-testid': 'component-zero' }));
  svg.append(grid);
  svg.append(el('text', { x: r2(L + (W - L - R) / 2), y: H - B + 36, 'text-anchor': 'middle', class: 'axis-title' }, `${A} position (mm)`));
  const my = r2((T + H - B) / 2);
  svg.append(el('text', { x: 13, y: my, 'text-anchor': 'middle', class: 'axis-title', transform: `rotate(-90 13 ${my})` }, 'Error (µm)'));

  const curves = el('g', { class: 'components-curves' });
  for (const s of series) {
    const d = us.map((u, i) => `${i ? 'L' : 'M'}${r2(px(u))},${r2(py(s.ys[i]))}`).join('');
    curves.append(
      el('path', {
        d,
        class: `components-curve ${s.dashed ? 'share' : s.kind}`,
        stroke: COLOUR[s.direction],
        'data-axis': m.axis,
        'data-direction': s.direction,
        'data-kind': s.kind,
        'data-pair': s.pair,
        // Component values (µm) at the two ends of the axis range, full precision.
        'data-end-values': JSON.stringify([s.f(m.lo), s.f(m.hi)]),
      }),
    );
  }
  svg.append(curves);

  // Legend below the axis title: curves in the left column, squareness shares in the right.
  const legend = el('g', { class: 'legend', 'data-testid': 'component-legend' });
  const rowY = (i) => H - B + 58 + i * 19;
  const entry = (x, y, s) => {
    const g = el('g', { transform: `translate(${x},${y})` });
    g.append(el('line', { x1: 0, y1: 0, x2: 24, y2: 0, class: `components-curve ${s.dashed ? 'share' : s.kind}`, stroke: COLOUR[s.direction] }));
    const t = el('text', { x: 30, y: 0, dy: '0.35em' });
    if (s.dashed) {
      t.append('squareness ½·S');
      t.append(el('tspan', { 'baseline-shift': 'sub', 'font-size': '75%' }, upper(s.pair)));
    } else {
      errorName(t, s.direction, m.axis);
      t.append(s.kind === 'positioning' ? ' positioning' : ' straightness');
    }
    g.append(t);
    legend.append(g);
  };
  series.filter((s) => !s.dashed).forEach((s, i) => entry(4, rowY(i), s));
  series.filter((s) => s.dashed).forEach((s, i) => entry(190, rowY(i), s));
  svg.append(legend);
  return svg;
}

// One row per component (E_AA, E_BA, …), one value ± σ column pair per Legendre order.
function termTable(dec) {
  const terms = (Array.isArray(dec?.terms) ? dec.terms : []).filter((t) => AXES.includes(t.axis) && AXES.includes(t.direction));
  const orders = [...new Set(terms.map((t) => t.order))].sort((p, q) => p - q);
  const h = (name, attrs, ...children) => {
    const node = document.createElement(name);
    for (const [k, v] of Object.entries(attrs || {})) node.setAttribute(k, String(v));
    node.append(...children);
    return node;
  };
  const caption = h('caption', {}, 'Legendre terms of the curves (µm at the + end of the axis; at the − end odd orders change sign)');
  const head = h(
    'thead',
    {},
    h(
      'tr',
      {},
      h('th', { scope: 'col' }, 'Component'),
      ...orders.flatMap((k) => [
        h('th', { scope: 'col', class: 'num' }, `Order ${k}`),
        h('th', { scope: 'col', class: 'num', title: 'standard uncertainty of this term alone' }, '± σ'),
      ]),
    ),
  );
  const body = h('tbody', {});
  if (!terms.length) body.append(h('tr', {}, h('td', { class: 'text-left' }, 'No terms above order 1 (scales and squareness only).')));
  for (const a of AXES) {
    // Positioning first, then the two straightness components of the axis.
    for (const b of [a, ...AXES.filter((x) => x !== a)]) {
      const own = terms.filter((t) => t.axis === a && t.direction === b);
      if (!own.length) continue;
      const name = h('th', { scope: 'row' }, 'E', h('sub', {}, `${upper(b)}${upper(a)}`), a === b ? ` positioning of ${upper(a)}` : ` straightness of ${upper(a)} in ${upper(b)}`);
      const cells = orders.flatMap((k) => {
        const t = own.find((x) => x.order === k);
        return [
          h('td', { class: 'num', 'data-order': k, 'data-key': 'value' }, t ? formatNumber(t.value_um, '_um') : '—'),
          h('td', { class: 'num', 'data-order': k, 'data-key': 'sigma' }, t ? `± ${formatUncertainty(t.sigma_um)}` : ''),
        ];
      });
      body.append(h('tr', { 'data-axis': a, 'data-direction': b }, name, ...cells));
    }
  }
  return h('table', { class: 'figures small components-terms', 'data-testid': 'component-terms' }, caption, head, body);
}

// The block drawn under the volumetric error vectors: three charts, the notes, the term table
// and the components held at zero.
export function renderComponentCharts(dec) {
  const box = document.createElement('div');
  box.className = 'components';
  box.dataset.testid = 'component-charts';
  const heading = document.createElement('h3');
  heading.className = 'components-heading';
  heading.textContent = 'Geometric error components along each axis';
  box.append(heading);
  const row = document.createElement('div');
  row.className = 'components-grid';
  for (const m of componentModel(dec)) {
    if (m.curves.length) {
      row.append(componentChart(m));
    } else {
      const p = document.createElement('p');
      p.className = 'placeholder components-missing';
      p.textContent = `${upper(m.axis)} does not move in this map: no components along ${upper(m.axis)}.`;
      row.append(p);
    }
  }
  box.append(row);
  const note = document.createElement('p');
  note.className = 'note components-note';
  note.dataset.testid = 'component-note';
  note.textContent =
    'Solid: positioning = scale × (position − centre) + Legendre terms; straightness = Legendre terms of order ≥ 2 only ' +
    '(the linear part of a straightness cannot be told apart from the squareness and the best-fit rotation). ' +
    'Dashed: the squareness contribution −½·S·(position − centre), which the decomposition shares equally between the two axes of each plane. ' +
    'Constant offsets are removed (best-fit placement).';
  const band = document.createElement('p');
  band.className = 'note components-note';
  band.dataset.testid = 'component-uncertainty';
  band.textContent =
    `No ±1σ band: the terms are correlated (σ ${dec?.uncertainty || 'of unknown origin'}) and their covariance is not reported; ` +
    'uncertainty per term in the table (scales and squareness in the decomposition table).';
  box.append(note, band, termTable(dec));
  const fixed = Array.isArray(dec?.fixed) ? dec.fixed : [];
  if (fixed.length) {
    const p = document.createElement('p');
    p.className = 'note components-note';
    p.textContent = 'Not identifiable from this map (held at zero):';
    const ul = document.createElement('ul');
    ul.className = 'fixed-terms components-fixed';
    ul.dataset.testid = 'component-fixed';
    for (const t of fixed) {
      const li = document.createElement('li');
      li.textContent = String(t);
      ul.append(li);
    }
    box.append(p, ul);
  }
  return box;
}
