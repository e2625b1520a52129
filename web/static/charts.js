// Small inline-SVG charts for the dashboard: horizontal bars of the diagnosis contributions,
// grouped bars of the DBB harmonic amplitudes, the straightness / parallelism profile with its
// reference lines, and the flatness colour map. Every chart carries data-* attributes with the
// plotted numbers so what is drawn can be checked against the API.

import { effectWords, niceStep, formatStep } from './format.js';
import { DIRECTION_STYLE } from './polar.js';
import { el, r2 } from './dom.js';

// The SVG helpers live in dom.js; charts.js passes them on to its users.
export { el, r2 };
const minus = (s) => String(s).replace('-', '−');

// Tick values from lo to hi with a 1-2-5 step giving about `count` intervals.
// The width a chart is drawn for: that of its box (at most 900 px, at least 340), so that on a
// phone its text stays legible instead of being scaled down with a wide drawing.
export function chartWidth(box) {
  const w = box && box.clientWidth ? box.clientWidth - 4 : 900;
  return Math.round(Math.max(340, Math.min(900, w)));
}

export function ticks(lo, hi, count = 5) {
  const step = niceStep((hi - lo) / count || 1);
  const out = [];
  for (let v = Math.ceil(lo / step - 1e-9) * step; v <= hi + step * 1e-9; v += step) out.push(Math.abs(v) < step * 1e-9 ? 0 : v);
  return { values: out, step };
}

export function tickText(v, step) {
  const decimals = Math.max(0, -Math.floor(Math.log10(step) + 1e-9));
  return minus(v.toFixed(decimals));
}

// ---------------------------------------------------------------- contribution bars

// rows: [{effect, contribution_pct}], ranked. `unexplained` (0..100) is drawn last in grey.
// Grid lines, tick labels and the frame of a chart with linear axes, as one <g class="grid">.
// px / py map data to pixels; xt / yt are ticks() results; the plot area is the box inside
// the margins L, R, T, B of a W × H chart. xTickGap / yTickGap: distance of the labels.
export function axesGrid({ W, H, L, R, T, B, px, py, xt, yt, xTickGap = 18, yTickGap = 7 }) {
  const grid = el('g', { class: 'grid' });
  for (const v of xt.values) {
    grid.append(el('line', { x1: r2(px(v)), x2: r2(px(v)), y1: T, y2: H - B, class: 'gridline' }));
    grid.append(el('text', { x: r2(px(v)), y: H - B + xTickGap, 'text-anchor': 'middle', class: 'tick' }, tickText(v, xt.step)));
  }
  for (const v of yt.values) {
    grid.append(el('line', { x1: L, x2: W - R, y1: r2(py(v)), y2: r2(py(v)), class: 'gridline' }));
    grid.append(el('text', { x: L - yTickGap, y: r2(py(v)), dy: '0.35em', 'text-anchor': 'end', class: 'tick' }, tickText(v, yt.step)));
  }
  grid.append(el('rect', { x: L, y: T, width: W - L - R, height: H - T - B, class: 'frame' }));
  return grid;
}

export function renderContributionChart(rows, { unexplained = null, title = 'Contribution to the circularity' } = {}) {
  const items = rows.map((r) => ({ label: effectWords(r.effect), key: r.effect, pct: Number(r.contribution_pct) || 0 }));
  if (unexplained !== null) items.push({ label: 'Not explained (noise, other)', key: '', pct: unexplained, rest: true });
  const W = 560;
  const LABEL_W = 215;
  const VALUE_W = 62;
  const BAR_H = 24;
  const GAP = 9;
  const TOP = 8;
  const AXIS_H = 26;
  const H = TOP + items.length * (BAR_H + GAP) + AXIS_H;
  const plotW = W - LABEL_W - VALUE_W;
  const max = Math.max(100, ...items.map((i) => i.pct)) || 100;
  const x = (p) => LABEL_W + (p / max) * plotW;
  const svg = el('svg', {
    viewBox: `0 0 ${W} ${H}`,
    width: W,
    height: H,
    role: 'img',
    class: 'chart bars',
    'data-testid': 'contribution-chart',
    'aria-label': `${title}: ${items.map((i) => `${i.label} ${i.pct.toFixed(1)} %`).join('; ')}.`,
  });
  svg.append(el('title', {}, title));
  const grid = el('g', { class: 'grid' });
  for (const p of [0, 25, 50, 75, 100]) {
    grid.append(el('line', { x1: r2(x(p)), x2: r2(x(p)), y1: TOP - 4, y2: H - AXIS_H + 2, class: p === 0 ? 'axis' : 'gridline' }));
    grid.append(el('text', { x: r2(x(p)), y: H - 8, 'text-anchor': 'middle', class: 'tick' }, `${p} %`));
  }
  svg.append(grid);
  items.forEach((it, i) => {
    const y = TOP + i * (BAR_H + GAP);
    const g = el('g', { class: it.rest ? 'bar rest' : 'bar', 'data-effect': it.key, 'data-pct': it.pct });
    g.append(el('text', { x: LABEL_W - 8, y: y + BAR_H / 2, dy: '0.35em', 'text-anchor': 'end', class: 'bar-label' }, it.label));
    g.append(el('rect', { x: r2(x(0)), y, width: r2(Math.max(0, x(it.pct) - x(0))), height: BAR_H, rx: 2 }));
    g.append(el('text', { x: r2(x(it.pct) + 6), y: y + BAR_H / 2, dy: '0.35em', class: 'bar-value' }, `${it.pct.toFixed(1)} %`));
    svg.append(g);
  });
  return svg;
}

// ---------------------------------------------------------------- harmonic bars

// series: [{direction, harmonics: [{order, amplitude_um}]}] — grouped bars by order.
export function renderHarmonicsChart(series, { title = 'Harmonic amplitudes of the radial error' } = {}) {
  const orders = [...new Set(series.flatMap((s) => (s.harmonics || []).map((h) => h.order)))].sort((a, b) => a - b);
  const maxAmp = Math.max(1e-3, ...series.flatMap((s) => (s.harmonics || []).map((h) => h.amplitude_um)));
  const W = 560;
  const H = 250;
  const L = 58;
  const R = 10;
  const T = 30;
  const B = 44;
  const { values: yt, step } = ticks(0, maxAmp * 1.12, 4);
  const top = yt[yt.length - 1] >= maxAmp ? yt[yt.length - 1] : yt[yt.length - 1] + step;
  const y = (v) => T + (H - T - B) * (1 - v / top);
  const groupW = (W - L - R) / Math.max(1, orders.length);
  const barW = Math.min(26, (groupW * 0.8) / Math.max(1, series.length));
  const svg = el('svg', {
    viewBox: `0 0 ${W} ${H}`,
    width: W,
    height: H,
    role: 'img',
    class: 'chart harmonics',
    'data-testid': 'harmonics-chart',
    'aria-label': `${title}, orders ${orders[0] ?? ''} to ${orders[orders.length - 1] ?? ''}; largest ${maxAmp.toFixed(3)} µm.`,
  });
  svg.append(el('title', {}, title));
  const grid = el('g', { class: 'grid' });
  for (const v of yt.concat(top > yt[yt.length - 1] ? [top] : [])) {
    grid.append(el('line', { x1: L, x2: W - R, y1: r2(y(v)), y2: r2(y(v)), class: v === 0 ? 'axis' : 'gridline' }));
    grid.append(el('text', { x: L - 6, y: r2(y(v)), dy: '0.35em', 'text-anchor': 'end', class: 'tick' }, tickText(v, step)));
  }
  svg.append(grid);
  svg.append(el('text', { x: 12, y: r2((T + H - B) / 2), class: 'axis-title', transform: `rotate(-90 12 ${r2((T + H - B) / 2)})`, 'text-anchor': 'middle' }, 'Amplitude (µm)'));
  svg.append(el('text', { x: r2(L + (W - L - R) / 2), y: H - 6, class: 'axis-title', 'text-anchor': 'middle' }, 'Harmonic order (cycles per turn)'));
  orders.forEach((order, gi) => {
    const cx = L + groupW * (gi + 0.5);
    svg.append(el('text', { x: r2(cx), y: H - B + 16, 'text-anchor': 'middle', class: 'tick' }, String(order)));
    series.forEach((s, si) => {
      const h = (s.harmonics || []).find((k) => k.order === order);
      if (!h) return;
      const style = DIRECTION_STYLE[s.direction] || { colour: '#4f5d6b' };
      const x0 = cx - (barW * series.length) / 2 + si * barW;
      svg.append(
        el('rect', {
          x: r2(x0 + 1), y: r2(y(h.amplitude_um)), width: r2(barW - 2), height: r2(Math.max(0, y(0) - y(h.amplitude_um))),
          fill: style.colour, class: order === 1 ? 'setup' : '',
          'data-order': order, 'data-direction': s.direction || '', 'data-amplitude-um': h.amplitude_um,
        }, ),
      );
    });
  });
  // Legend (top right).
  const legend = el('g', { class: 'legend', transform: `translate(${W - R - 8},${12})` });
  [...series].reverse().forEach((s, i) => {
    const style = DIRECTION_STYLE[s.direction] || { colour: '#4f5d6b' };
    const xx = -i * 80;
    legend.append(el('rect', { x: xx - 58, y: -7, width: 14, height: 14, fill: style.colour }));
    legend.append(el('text', { x: xx - 40, y: 0, dy: '0.35em' }, String(s.direction || '').toUpperCase()));
  });
  svg.append(legend);
  return svg;
}

// ---------------------------------------------------------------- profile plot

// Straightness / parallelism profile. opts:
//   x[], y[]           plotted values (µm), already referred to what the plot shows
//   lines: [{label, cls, y0, slope (µm per mm), dash}] reference lines across the travel
//   band: {lo0, hi0, slope, label, cls} shaded band between two parallel lines
//   xLabel, yLabel, title
export function renderProfilePlot({ x, y, lines = [], bands = [], xLabel, yLabel, title }) {
  const W = 900;
  const H = 350;
  const L = 70;
  const R = 16;
  const T = 36; // room for the legend above the frame
  const B = 52;
  const n = Math.min(x.length, y.length);
  const xmin = Math.min(...x);
  const xmax = Math.max(...x);
  const yVals = [...y];
  const at = (l, xx) => l.y0 + l.slope * xx;
  for (const l of [...lines, ...bands.flatMap((b) => [{ y0: b.lo0, slope: b.slope }, { y0: b.hi0, slope: b.slope }])]) {
    yVals.push(at(l, xmin), at(l, xmax));
  }
  let ylo = Math.min(...yVals);
  let yhi = Math.max(...yVals);
  const pad = (yhi - ylo) * 0.08 || 0.5;
  ylo -= pad;
  yhi += pad;
  const xt = ticks(xmin, xmax, 8);
  const yt = ticks(ylo, yhi, 6);
  const px = (v) => L + ((v - xmin) / (xmax - xmin || 1)) * (W - L - R);
  const py = (v) => T + (1 - (v - ylo) / (yhi - ylo || 1)) * (H - T - B);
  const svg = el('svg', {
    viewBox: `0 0 ${W} ${H}`,
    width: W,
    height: H,
    role: 'img',
    class: 'chart profile',
    'data-testid': 'profile-plot',
    'data-px-per-um': (H - T - B) / (yhi - ylo),
    'aria-label': `${title}: ${yLabel} against ${xLabel}, ${n} points.`,
  });
  svg.append(el('title', {}, title));
  svg.append(axesGrid({ W, H, L, R, T, B, px, py, xt, yt }));
  svg.append(el('text', { x: r2(L + (W - L - R) / 2), y: H - 10, 'text-anchor': 'middle', class: 'axis-title' }, xLabel));
  const my = r2((T + H - B) / 2);
  svg.append(el('text', { x: 16, y: my, 'text-anchor': 'middle', class: 'axis-title', transform: `rotate(-90 16 ${my})` }, yLabel));

  for (const b of bands) {
    const pts = [
      [px(xmin), py(b.lo0 + b.slope * xmin)], [px(xmax), py(b.lo0 + b.slope * xmax)],
      [px(xmax), py(b.hi0 + b.slope * xmax)], [px(xmin), py(b.hi0 + b.slope * xmin)],
    ];
    svg.append(el('polygon', {
      points: pts.map(([a, c]) => `${r2(a)},${r2(c)}`).join(' '), class: `band ${b.cls || ''}`,
      'data-testid': b.testid, 'data-width-um': b.hi0 - b.lo0, 'data-slope-um-per-mm': b.slope,
    }));
    for (const y0 of [b.lo0, b.hi0]) {
      svg.append(el('line', {
        x1: r2(px(xmin)), y1: r2(py(y0 + b.slope * xmin)), x2: r2(px(xmax)), y2: r2(py(y0 + b.slope * xmax)),
        class: `band-edge ${b.cls || ''}`,
      }));
    }
  }
  for (const l of lines) {
    svg.append(el('line', {
      x1: r2(px(xmin)), y1: r2(py(at(l, xmin))), x2: r2(px(xmax)), y2: r2(py(at(l, xmax))),
      class: `ref ${l.cls || ''}`, 'data-testid': l.testid,
    }));
  }
  const d = [];
  for (let i = 0; i < n; ++i) d.push(`${i ? 'L' : 'M'}${r2(px(x[i]))},${r2(py(y[i]))}`);
  svg.append(el('path', { d: d.join(''), class: 'data-line', 'data-points': n, 'data-testid': 'profile-trace' }));
  if (n <= 400) {
    const dots = el('g', { class: 'dots' });
    for (let i = 0; i < n; ++i) dots.append(el('circle', { cx: r2(px(x[i])), cy: r2(py(y[i])), r: n > 120 ? 1.8 : 3 }));
    svg.append(dots);
  }
  // Legend (top, inside the frame).
  const legend = el('g', { class: 'legend', 'data-testid': 'profile-legend' });
  const entries = [{ label: 'Measured', cls: 'data-line', kind: 'line' }, ...bands.map((b) => ({ ...b, kind: 'band' })), ...lines.map((l) => ({ ...l, kind: 'ref' }))];
  let lx = L;
  for (const e of entries) {
    const g = el('g', { transform: `translate(${r2(lx)},${T - 17})` });
    if (e.kind === 'band') g.append(el('rect', { x: 0, y: -7, width: 26, height: 14, class: `band ${e.cls || ''}` }));
    else g.append(el('line', { x1: 0, y1: 0, x2: 26, y2: 0, class: e.kind === 'ref' ? `ref ${e.cls || ''}` : 'data-line' }));
    g.append(el('text', { x: 32, y: 0, dy: '0.35em' }, e.label));
    legend.append(g);
    lx += 46 + e.label.length * 8;
  }
  svg.append(legend);
  return svg;
}

// ---------------------------------------------------------------- flatness colour map

// Diverging blue–white–red colour for t in [-1, 1].
function diverging(t) {
  const c = Math.max(-1, Math.min(1, t));
  const lerp = (a, b, u) => Math.round(a + (b - a) * u);
  const white = [247, 247, 247];
  const blue = [33, 102, 172];
  const red = [178, 24, 43];
  const end = c < 0 ? blue : red;
  const u = Math.abs(c);
  return `rgb(${lerp(white[0], end[0], u)},${lerp(white[1], end[1], u)},${lerp(white[2], end[2], u)})`;
}

// Cell labels: 2 decimals for a few µm, 1 beyond; no "−0.00".
function cellNumber(v, span) {
  const decimals = span < 10 ? 2 : 1;
  let s = v.toFixed(decimals);
  if (/^-0\.?0*$/.test(s)) s = s.slice(1);
  return minus(s);
}

// points: [{x, y, v}] with v the deviation from the reference plane in µm.
export function renderColourMap(points, { title = 'Flatness map', xLabel = 'X (mm)', yLabel = 'Y (mm)' } = {}) {
  const xs = [...new Set(points.map((p) => p.x))].sort((a, b) => a - b);
  const ys = [...new Set(points.map((p) => p.y))].sort((a, b) => a - b);
  const isGrid = xs.length * ys.length === points.length && xs.length > 1 && ys.length > 1;
  const maxAbs = Math.max(1e-3, ...points.map((p) => Math.abs(p.v)));
  const { values: scaleTicks, step } = ticks(-maxAbs, maxAbs, 8);
  const span = Math.max(maxAbs, Math.abs(scaleTicks[0]), Math.abs(scaleTicks[scaleTicks.length - 1]));
  const xmin = xs[0];
  const xmax = xs[xs.length - 1];
  const ymin = ys[0];
  const ymax = ys[ys.length - 1];
  // Cell size: the grid spacing (or a fraction of the extent for scattered points).
  const dx = isGrid ? (xmax - xmin) / (xs.length - 1) : (xmax - xmin) / 12 || 1;
  const dy = isGrid ? (ymax - ymin) / (ys.length - 1) : (ymax - ymin) / 12 || 1;
  const ex0 = xmin - dx / 2;
  const ex1 = xmax + dx / 2;
  const ey0 = ymin - dy / 2;
  const ey1 = ymax + dy / 2;
  const L = 64;
  const T = 12;
  const MAP_W = 560;
  const MAP_H = Math.max(200, Math.min(420, (MAP_W * (ey1 - ey0)) / (ex1 - ex0)));
  const B = 50;
  const SCALE_W = 110;
  const W = L + MAP_W + 30 + SCALE_W;
  const H = T + MAP_H + B;
  const px = (v) => L + ((v - ex0) / (ex1 - ex0)) * MAP_W;
  const py = (v) => T + (1 - (v - ey0) / (ey1 - ey0)) * MAP_H;
  const svg = el('svg', {
    viewBox: `0 0 ${W} ${r2(H)}`,
    width: W,
    height: r2(H),
    role: 'img',
    class: 'chart colour-map',
    'data-testid': 'flatness-map',
    'data-scale-um': span,
    'aria-label': `${title}: deviation from the least-squares plane at ${points.length} points, colour scale ±${formatStep(Number(span.toPrecision(3)))} µm.`,
  });
  svg.append(el('title', {}, title));
  const cellW = (MAP_W * dx) / (ex1 - ex0);
  const cellH = (MAP_H * dy) / (ey1 - ey0);
  const showText = cellW >= 44 && cellH >= 22;
  const cells = el('g', { class: 'cells' });
  for (const p of points) {
    const fill = diverging(p.v / span);
    const attrs = { fill, 'data-x-mm': p.x, 'data-y-mm': p.y, 'data-um': p.v };
    if (isGrid) {
      cells.append(el('rect', { ...attrs, x: r2(px(p.x - dx / 2)), y: r2(py(p.y + dy / 2)), width: r2(cellW), height: r2(cellH) }));
    } else {
      cells.append(el('circle', { ...attrs, cx: r2(px(p.x)), cy: r2(py(p.y)), r: r2(Math.max(5, Math.min(cellW, cellH) / 2.2)) }));
    }
    if (showText) {
      cells.append(el('text', {
        x: r2(px(p.x)), y: r2(py(p.y)), dy: '0.35em', 'text-anchor': 'middle',
        class: Math.abs(p.v / span) > 0.6 ? 'cell-value dark' : 'cell-value',
      }, cellNumber(p.v, span)));
    }
  }
  svg.append(cells);
  svg.append(el('rect', { x: L, y: T, width: MAP_W, height: r2(MAP_H), class: 'frame' }));
  // Axes.
  const axes = el('g', { class: 'grid' });
  const xt = ticks(xmin, xmax, 6);
  const yt = ticks(ymin, ymax, 5);
  for (const v of xt.values) axes.append(el('text', { x: r2(px(v)), y: r2(T + MAP_H + 17), 'text-anchor': 'middle', class: 'tick' }, tickText(v, xt.step)));
  for (const v of yt.values) axes.append(el('text', { x: L - 7, y: r2(py(v)), dy: '0.35em', 'text-anchor': 'end', class: 'tick' }, tickText(v, yt.step)));
  svg.append(axes);
  svg.append(el('text', { x: r2(L + MAP_W / 2), y: r2(H - 8), 'text-anchor': 'middle', class: 'axis-title' }, xLabel));
  const my = r2(T + MAP_H / 2);
  svg.append(el('text', { x: 16, y: my, 'text-anchor': 'middle', class: 'axis-title', transform: `rotate(-90 16 ${my})` }, yLabel));
  // Colour scale: a vertical bar from −span (bottom) to +span (top).
  const sx = L + MAP_W + 30;
  const sh = MAP_H;
  const scale = el('g', { class: 'colour-scale', 'data-testid': 'colour-scale' });
  const STEPS = 40;
  for (let i = 0; i < STEPS; ++i) {
    const t0 = 1 - (2 * i) / STEPS;
    scale.append(el('rect', { x: sx, y: r2(T + (sh * i) / STEPS), width: 22, height: r2(sh / STEPS + 0.5), fill: diverging(t0 - 1 / STEPS) }));
  }
  scale.append(el('rect', { x: sx, y: T, width: 22, height: r2(sh), class: 'frame' }));
  for (const v of scaleTicks) {
    if (Math.abs(v) > span * (1 + 1e-9)) continue;
    const yy = T + sh * (1 - (v + span) / (2 * span));
    scale.append(el('line', { x1: sx + 22, x2: sx + 27, y1: r2(yy), y2: r2(yy), class: 'axis' }));
    scale.append(el('text', { x: sx + 30, y: r2(yy), dy: '0.35em', class: 'tick' }, `${v > 0 ? '+' : ''}${tickText(v, step)}`));
  }
  scale.append(el('text', { x: sx + 11, y: r2(T + sh + 20), 'text-anchor': 'middle', class: 'axis-title' }, 'µm'));
  svg.append(scale);
  return svg;
}
