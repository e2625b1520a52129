// Polar plot of DBB traces as inline SVG, the usual ballbar presentation: the nominal circle
// is drawn at a fixed size and the radial error (µm) is magnified about it, so a point at
// angle θ with error e sits at radius R0 + e·k (k px per µm). Rings every "div" µm show the
// scale; the magnification is k / (R0 / radius) — how much more the error is enlarged than
// the circle itself.

import { niceStep, formatStep } from './format.js';
import { el, r2 } from './dom.js';

const HALF = 300; // half the viewBox size, px
const R0 = 150; // nominal circle radius, px
const PX_PER_DIV = 36; // ring spacing, px
const RINGS = 3; // rings on each side of the nominal circle
const FILL_DIVS = 2.6; // the largest |error| uses at most this many divisions

// The colours of the server's plot (render/dbb_plot.cpp: CCW blue, CW red), so that the page's
// plot, its saved PNG and the server's PNG and PDF read alike.
export const DIRECTION_STYLE = {
  ccw: { colour: '#143cc8', dash: '', label: 'CCW (counter-clockwise)' },
  cw: { colour: '#d21e1e', dash: '7 4', label: 'CW (clockwise)' },
};

// Chooses the scale shared by all traces: µm per division from the 1-2-5 series (the server's
// render::DbbPageScale is the same rule, for the PDF; the server's PNG is asked at this scale).
export function chooseScale(traces) {
  let maxAbs = 0;
  for (const t of traces) {
    for (const e of t.radial_error_um || []) {
      if (Number.isFinite(e)) maxAbs = Math.max(maxAbs, Math.abs(e));
    }
  }
  const umPerDiv = niceStep(Math.max(maxAbs, 1e-3) / FILL_DIVS);
  return { umPerDiv, pxPerUm: PX_PER_DIV / umPerDiv, maxAbsUm: maxAbs };
}

export function magnification(pxPerUm, radiusMm) {
  if (!(radiusMm > 0)) return null;
  return (pxPerUm * radiusMm * 1000) / R0;
}

function formatMagnification(m) {
  const digits = Math.max(0, Math.floor(Math.log10(m)) - 1); // keep 2 significant digits
  const rounded = Math.round(m / 10 ** digits) * 10 ** digits;
  return `×${rounded.toLocaleString('en-US').replace(/,/g, '\u2009')}`;
}

// traces: [{direction, angle_deg[], radial_error_um[], radius_mm, test_id}]
// Returns an <svg> element.
export function renderPolarPlot(traces, { title = 'DBB polar plot' } = {}) {
  const { umPerDiv, pxPerUm, maxAbsUm } = chooseScale(traces);
  const radiusMm = traces.find((t) => t.radius_mm > 0)?.radius_mm;
  const mag = magnification(pxPerUm, radiusMm);
  const scaleText = `${formatStep(umPerDiv)} µm/div`;
  const magText = mag ? formatMagnification(mag) : '';

  const svg = el('svg', {
    viewBox: `${-HALF} ${-HALF} ${2 * HALF} ${2 * HALF}`,
    width: 2 * HALF,
    height: 2 * HALF,
    role: 'img',
    class: 'polar',
    'data-um-per-div': umPerDiv,
    'data-divisions': RINGS,
    'data-px-per-um': pxPerUm,
    'data-nominal-px': R0,
    'data-magnification': mag ? r2(mag) : '',
  });
  const dirs = traces.map((t) => String(t.direction).toUpperCase()).join(' and ');
  svg.setAttribute(
    'aria-label',
    `${title}: ${dirs} radial error about the nominal circle` +
      `${radiusMm ? ` of radius ${radiusMm} mm` : ''}, scale ${scaleText}` +
      `${magText ? `, magnification ${magText}` : ''}; largest deviation ${maxAbsUm.toFixed(3)} µm.`,
  );
  svg.append(el('title', {}, title));

  // Grid: rings at ±k divisions, the nominal circle emphasised; axes every 30°.
  const grid = el('g', { class: 'grid' });
  for (let deg = 0; deg < 180; deg += 30) {
    const a = (deg * Math.PI) / 180;
    const R = R0 + RINGS * PX_PER_DIV;
    grid.append(
      el('line', {
        x1: r2(-R * Math.cos(a)), y1: r2(R * Math.sin(a)),
        x2: r2(R * Math.cos(a)), y2: r2(-R * Math.sin(a)),
        class: deg % 90 === 0 ? 'axis' : 'spoke',
      }),
    );
  }
  for (let k = -RINGS; k <= RINGS; ++k) {
    grid.append(
      el('circle', {
        cx: 0, cy: 0, r: R0 + k * PX_PER_DIV,
        class: k === 0 ? 'nominal' : 'ring',
        'data-ring-um': r2(k * umPerDiv),
      }),
    );
  }
  svg.append(grid);

  // Ring labels in µm along the 75° direction (between spokes, clear of the angle labels).
  const labels = el('g', { class: 'ring-labels' });
  const la = (75 * Math.PI) / 180;
  for (let k = -RINGS; k <= RINGS; ++k) {
    const R = R0 + k * PX_PER_DIV;
    const v = k * umPerDiv;
    const text = k === 0 ? '0' : `${k > 0 ? '+' : '−'}${formatStep(Math.abs(v))}`;
    labels.append(el('text', { x: r2(R * Math.cos(la)), y: r2(-R * Math.sin(la)), dy: '0.35em' }, text));
  }
  svg.append(labels);

  // Angle labels.
  const angles = el('g', { class: 'angle-labels' });
  for (let deg = 0; deg < 360; deg += 90) {
    const a = (deg * Math.PI) / 180;
    const vertical = deg % 180 !== 0;
    const R = R0 + RINGS * PX_PER_DIV + (vertical ? 16 : 6);
    const anchor = vertical ? 'middle' : deg === 0 ? 'start' : 'end';
    angles.append(
      el('text', { x: r2(R * Math.cos(a)), y: r2(-R * Math.sin(a)), dy: '0.35em', 'text-anchor': anchor }, `${deg}°`),
    );
  }
  svg.append(angles);

  // Traces.
  for (const t of traces) {
    // A trace may bring its own style (an overlaid test for comparison).
    const style = t.style || DIRECTION_STYLE[t.direction] || { colour: '#333', dash: '', label: t.direction };
    const n = Math.min(t.angle_deg?.length || 0, t.radial_error_um?.length || 0);
    const parts = [];
    for (let i = 0; i < n; ++i) {
      const a = (t.angle_deg[i] * Math.PI) / 180;
      const e = t.radial_error_um[i];
      if (!Number.isFinite(a) || !Number.isFinite(e)) continue;
      const R = Math.max(0, R0 + e * pxPerUm);
      parts.push(`${parts.length ? 'L' : 'M'}${r2(R * Math.cos(a))},${r2(-R * Math.sin(a))}`);
    }
    if (parts.length > 2) parts.push('Z');
    svg.append(
      el('path', {
        d: parts.join(''),
        class: `trace trace-${t.direction}`,
        stroke: style.colour,
        'stroke-dasharray': style.dash || 'none',
        'data-direction': t.direction,
        'data-points': n,
        'data-testid': t.role ? `trace-${t.role}` : `trace-${t.direction}`,
        'data-role': t.role || null,
        'data-measurement-id': t.id ?? null,
      }),
    );
  }

  // Legend (top left) and scale (bottom left), inside the picture so it stands on its own.
  const legend = el('g', { class: 'legend', 'data-testid': 'plot-legend', transform: `translate(${-HALF + 6},${-HALF + 16})` });
  traces.forEach((t, i) => {
    const style = t.style || DIRECTION_STYLE[t.direction] || { colour: '#333', dash: '', label: t.direction };
    const y = i * 26;
    legend.append(
      el('line', { x1: 0, y1: y, x2: 30, y2: y, stroke: style.colour, 'stroke-dasharray': style.dash || 'none', class: 'legend-swatch' }),
      el('text', { x: 38, y, dy: '0.35em', 'data-direction': t.direction }, style.label),
    );
  });
  svg.append(legend);

  const scale = el('g', { class: 'scale', transform: `translate(${-HALF + 6},${HALF - 32})` });
  scale.append(el('text', { x: 0, y: 0, 'data-testid': 'plot-scale' }, `Scale ${scaleText}`));
  if (magText) scale.append(el('text', { x: 0, y: 24, 'data-testid': 'plot-magnification' }, `Magnification ${magText}`));
  svg.append(scale);

  return { svg, umPerDiv, pxPerUm, magnification: mag, scaleText, magText };
}
