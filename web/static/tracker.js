// Volumetric error vector plot of a laser-tracker self-calibration (kind "tracker"): the
// commanded points are drawn in two orthographic views, XY (top) and XZ (front), and each
// point carries an arrow = volumetric error (µm) × magnification, drawn in the same mm scale
// as the points. Points the analysis dropped (error null) are drawn hollow, without arrow.
// The scale bar shows what a given µm length looks like after magnification.

import { formatStep, niceStep } from './format.js';
import { el, r2 } from './dom.js';

const VIEW = 300; // size of one view, px
const PAD = 34; // inner margin of a view, px
const GAP = 28; // between the two views, px
const TOP = 34; // title row, px
const BOTTOM = 64; // scale bar + legend, px
const ARROW_FRACTION = 0.55; // the longest arrow is at most this share of the point spacing

// Largest 1-2-5 value ≤ x.
function niceFloor(x) {
  const up = niceStep(x);
  if (up <= x * (1 + 1e-9)) return up;
  const exp = Math.floor(Math.log10(x));
  const base = 10 ** exp;
  for (const m of [5, 2, 1]) if (m * base <= x * (1 + 1e-9)) return m * base;
  return base;
}

// points: [[x, y, z] mm], errors: [[ex, ey, ez] µm or null].
const f3 = (v) => (Number.isFinite(v) ? v.toFixed(3).replace('-', '−') : '—');

// "Point 12 at X 100.000, Y 200.000, Z 50.000 mm: error X 1.234, Y −0.500, Z 0.250 µm
// (1.354 µm)"; a dropped point says so.
export function pointText(i, p, e) {
  const at = `Point ${i + 1} at X ${f3(p[0])}, Y ${f3(p[1])}, Z ${f3(p[2])} mm`;
  if (!e) return `${at}: dropped (no error estimate)`;
  const len = Math.hypot(e[0], e[1], e[2]);
  return `${at}: error X ${f3(e[0])}, Y ${f3(e[1])}, Z ${f3(e[2])} µm (${f3(len)} µm)`;
}

export function renderTrackerVectorPlot(points, errors, { title = 'Volumetric error' } = {}) {
  const n = points.length;
  const lo = [0, 1, 2].map((a) => Math.min(...points.map((p) => p[a])));
  const hi = [0, 1, 2].map((a) => Math.max(...points.map((p) => p[a])));
  const span = Math.max(...[0, 1, 2].map((a) => hi[a] - lo[a]), 1e-6);
  const pxPerMm = (VIEW - 2 * PAD) / span;
  // Typical spacing of the points along an axis: span / (distinct values − 1).
  const distinct = Math.max(2, ...[0, 1, 2].map((a) => new Set(points.map((p) => p[a].toFixed(3))).size));
  const spacingPx = ((VIEW - 2 * PAD) / (distinct - 1)) || VIEW / 4;
  let maxUm = 0;
  for (const e of errors) if (e) maxUm = Math.max(maxUm, Math.hypot(e[0], e[1], e[2]));
  const wantPx = ARROW_FRACTION * spacingPx;
  const magnification = niceFloor(wantPx / (Math.max(maxUm, 1e-3) * 1e-3 * pxPerMm));
  const pxPerUm = 1e-3 * magnification * pxPerMm;
  const width = 2 * VIEW + GAP;
  const height = TOP + VIEW + BOTTOM;
  const svg = el('svg', {
    viewBox: `0 0 ${width} ${height}`,
    class: 'chart tracker-vectors',
    role: 'img',
    'aria-label': `${title}: XY and XZ views of ${n} points, errors magnified ×${magnification}`,
    'data-testid': 'tracker-vector-plot',
    'data-magnification': magnification,
    'data-px-per-um': pxPerUm,
    'data-px-per-mm': pxPerMm,
    'data-points': n,
  });
  svg.append(el('title', {}, title));
  svg.append(el('defs'));
  // Points behind one another in a view (other depth) get lighter shades of the arrow colour.
  const SHADES = ['#0b3d91', '#0b5cad', '#3d8bd9', '#7fb2e5'];
  for (const [k, c] of SHADES.entries()) {
    const marker = el('marker', { id: `tv-head-${k}`, viewBox: '0 0 10 10', refX: 9, refY: 5, markerWidth: 6, markerHeight: 6, markerUnits: 'userSpaceOnUse', orient: 'auto' });
    marker.append(el('path', { d: 'M0,0 L10,5 L0,10 Z', fill: c }));
    svg.querySelector('defs').append(marker);
  }

  const views = [
    { id: 'xy', axes: [0, 1], label: 'XY view (from above)', names: ['X', 'Y'] },
    { id: 'xz', axes: [0, 2], label: 'XZ view (from the front)', names: ['X', 'Z'] },
  ];
  views.forEach((v, k) => {
    const ox = k * (VIEW + GAP);
    const [a, b] = v.axes;
    const depthAxis = 3 - a - b;
    const depths = [...new Set(points.map((p) => p[depthAxis]))].sort((p, q) => q - p);
    const shadeOf = (p) => {
      if (depths.length <= 1) return 1;
      const rank = depths.indexOf(p[depthAxis]) / (depths.length - 1); // 0 = nearest the viewer
      return Math.min(SHADES.length - 1, Math.round(rank * (SHADES.length - 1)));
    };
    const cx = (lo[a] + hi[a]) / 2;
    const cy = (lo[b] + hi[b]) / 2;
    const X = (mm) => ox + VIEW / 2 + (mm - cx) * pxPerMm;
    const Y = (mm) => TOP + VIEW / 2 - (mm - cy) * pxPerMm;
    const g = el('g', { class: 'view', 'data-view': v.id });
    g.append(el('rect', { class: 'frame', x: ox + 0.5, y: TOP + 0.5, width: VIEW - 1, height: VIEW - 1 }));
    g.append(el('text', { class: 'axis-title', x: ox + VIEW / 2, y: TOP - 10, 'text-anchor': 'middle' }, v.label));
    // Axis arrows at the lower left corner.
    const ax0 = ox + 10;
    const ay0 = TOP + VIEW - 10;
    g.append(el('line', { class: 'axis', x1: ax0, y1: ay0, x2: ax0 + 22, y2: ay0 }));
    g.append(el('line', { class: 'axis', x1: ax0, y1: ay0, x2: ax0, y2: ay0 - 22 }));
    g.append(el('text', { class: 'tick', x: ax0 + 25, y: ay0 + 4 }, v.names[0]));
    g.append(el('text', { class: 'tick', x: ax0 - 4, y: ay0 - 26 }, v.names[1]));
    const dots = el('g', { class: 'points' });
    const arrows = el('g', { class: 'vectors' });
    points.forEach((p, i) => {
      const e = errors[i];
      const x1 = r2(X(p[a]));
      const y1 = r2(Y(p[b]));
      dots.append(el('circle', { cx: x1, cy: y1, r: 2.2, class: e ? 'pt' : 'pt dropped', 'data-point': i }));
      // Hover (and screen readers): the point's position and its error, in numbers.
      const hit = el('circle', { cx: x1, cy: y1, r: 7, class: 'hit', 'data-hit-point': i, 'data-testid': 'tracker-point' });
      hit.append(el('title', {}, pointText(i, p, e)));
      dots.append(hit);
      if (!e) return;
      const x2 = r2(x1 + e[a] * pxPerUm);
      const y2 = r2(y1 - e[b] * pxPerUm);
      arrows.append(
        el('line', {
          class: 'vector',
          x1,
          y1,
          x2,
          y2,
          stroke: SHADES[shadeOf(p)],
          'marker-end': `url(#tv-head-${shadeOf(p)})`,
          'data-point': i,
          'data-view': v.id,
          'data-e1-um': e[a],
          'data-e2-um': e[b],
        }),
      );
    });
    g.append(dots, arrows);
    svg.append(g);
  });

  // Scale bar: a 1-2-5 µm length of about 60–120 px after magnification.
  const barUm = niceFloor(110 / pxPerUm);
  const barPx = barUm * pxPerUm;
  const sy = TOP + VIEW + 26;
  const scale = el('g', { class: 'scale', 'data-testid': 'tracker-scale', 'data-bar-um': barUm, 'data-bar-px': barPx });
  scale.append(el('line', { class: 'vector', x1: 10, y1: sy, x2: r2(10 + barPx), y2: sy }));
  scale.append(el('line', { class: 'axis', x1: 10, y1: sy - 5, x2: 10, y2: sy + 5 }));
  scale.append(el('line', { class: 'axis', x1: r2(10 + barPx), y1: sy - 5, x2: r2(10 + barPx), y2: sy + 5 }));
  scale.append(el('text', { class: 'scale-label', x: r2(18 + barPx), y: sy + 5 }, `${formatStep(barUm)} µm`));
  svg.append(scale);
  svg.append(
    el(
      'text',
      { class: 'legend-text', x: width - 10, y: sy + 5, 'text-anchor': 'end', 'data-testid': 'tracker-magnification' },
      `Errors magnified ×${magnification}; darker = nearer the viewer`,
    ),
  );
  svg.append(
    el(
      'text',
      { class: 'tick', x: 10, y: height - 8 },
      `Largest error ${maxUm.toFixed(3)} µm (3D length)` + (errors.some((e) => !e) ? '; hollow points were dropped' : ''),
    ),
  );
  return { svg, magnification, pxPerUm };
}
