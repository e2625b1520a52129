// The bar chart of a discovery's gap step by step (discovery_result.js): the gap of the base
// model, then after each step, with the noise floor as a dashed line.

import { axesGrid, el, r2, ticks } from './charts.js';

export function renderGapChart(bars, noiseFloor, { title = 'Gap between model and tests, step by step', narrow = false } = {}) {
  // Narrow screens get a narrower drawing, so that its text stays readable when scaled down.
  const W = narrow ? 370 : 560;
  const L = 14;
  const R = 104;
  const T = 12;
  const ROW = 50;
  const NOTE = 22; // the noise-floor label, under the last bar
  const B = 52;
  const H = T + ROW * bars.length + NOTE + B;
  const hasFloor = typeof noiseFloor === 'number' && Number.isFinite(noiseFloor);
  const hiData = Math.max(...bars.map((b) => b.gap), hasFloor ? noiseFloor : 0, 1e-3);
  const xt = ticks(0, hiData, 5);
  const hi = Math.max(hiData, xt.values[xt.values.length - 1]);
  const px = (v) => L + (v / hi) * (W - L - R);
  const svg = el('svg', {
    viewBox: `0 0 ${W} ${H}`,
    width: W,
    height: H,
    role: 'img',
    class: 'chart bars gap-chart',
    'data-testid': 'disc-gap-chart',
    'data-noise-floor-um': hasFloor ? noiseFloor : '',
    'data-px-per-um': (W - L - R) / hi,
    'data-zero-px': L,
    'aria-label':
      `${title}: ${bars.map((b) => `${b.label} ${b.gap.toFixed(3)} µm`).join('; ')}` +
      `${hasFloor ? `; noise floor ${noiseFloor.toFixed(3)} µm` : ''}.`,
  });
  svg.append(el('title', {}, title));
  svg.append(axesGrid({ W, H, L, R, T, B, px, py: (v) => v, xt, yt: { values: [], step: 1 } }));
  svg.append(el('text', { x: r2(L + (W - L - R) / 2), y: H - 10, 'text-anchor': 'middle', class: 'axis-title' }, 'Gap RMS (µm)'));
  // Layers: bars, the noise-floor line over them, the labels (with a white halo) on top.
  const g = el('g', { class: 'gap-bars' });
  const labels = el('g', { class: 'gap-labels' });
  bars.forEach((b, i) => {
    const y = T + i * ROW;
    const w = Math.max(1, px(b.gap) - L);
    const bar = el('g', {
      class: `bar${b.step === 0 ? ' base' : ''}`,
      'data-step': b.step,
      'data-effect': b.effect || '',
      'data-gap-um': b.gap,
    });
    bar.append(el('rect', { x: L, y: y + 23, width: r2(w), height: 20, rx: 2 }));
    g.append(bar);
    labels.append(el('text', { x: L + 4, y: y + 16, class: 'bar-label', 'data-step': b.step }, b.label));
    labels.append(el('text', { x: r2(L + w + 6), y: y + 38, class: 'bar-value', 'data-step': b.step }, `${b.gap.toFixed(3)} µm`));
  });
  svg.append(g);
  if (hasFloor) {
    const x = r2(px(noiseFloor));
    const yEnd = T + ROW * bars.length + NOTE;
    svg.append(el('line', { x1: x, x2: x, y1: T, y2: yEnd, class: 'noise-floor', 'data-testid': 'disc-noise-floor', 'data-um': noiseFloor }));
    const label = `noise floor ${noiseFloor.toFixed(3)} µm`;
    const right = x + 8 + label.length * 7.5 < W - 4;
    labels.append(el('text', { x: right ? x + 6 : x - 6, y: yEnd - 6, 'text-anchor': right ? 'start' : 'end', class: 'noise-label' }, label));
  }
  svg.append(labels);
  return svg;
}
