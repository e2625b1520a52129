// Words and numbers of the model-gap discovery page (discovery.js, discovery_result.js): effect
// and parameter names in words, values with their uncertainties, p-values, percentages.

import { h } from './dom.js';
import { effectWords, formatNumber } from './format.js';

export const minus = (s) => String(s).replace(/-/g, '−');

// Parameters of the hexapod effects (analysis/hexapod/effects/*.cpp) in words, with the unit
// they are shown in and the factor from the stored unit to it.
const PARAMETERS = {
  K_stiff2_mm_per_N: { label: 'Compliance of joints and platform (per strut)', unit: 'µm/kN', factor: 1e6 },
  torque_Nm: { label: 'Base-joint friction torque', unit: 'N·m', factor: 1 },
  ramp_mm: { label: 'Friction build-up after a reversal (ramp length)', unit: 'mm', factor: 1 },
  torque_per_N_m: { label: 'Friction torque per unit strut force', unit: 'N·m/kN', factor: 1e3 },
  lag_coefficient_ms2: { label: 'Servo lag coefficient (1 − K_f²)/K_pp²', unit: 'ms²', factor: 1 },
  rate_um_per_h: { label: 'Thermal drift rate', unit: 'µm/h', factor: 1 },
  um_per_K: { label: 'Thermal growth per kelvin', unit: 'µm/K', factor: 1 },
  strain_ppm_per_h: { label: 'Thermal growth with strut length', unit: 'µm/m per h', factor: 1 },
  ppm_per_K: { label: 'Thermal expansion of the struts (α)', unit: 'µm/m per K', factor: 1 },
  platform_mass_kg: { label: 'Platform mass', unit: 'kg', factor: 1 },
  'platform_cog_mm[0]': { label: 'Platform centre of gravity, x (platform frame)', unit: 'mm', factor: 1 },
  'platform_cog_mm[1]': { label: 'Platform centre of gravity, y (platform frame)', unit: 'mm', factor: 1 },
  'platform_cog_mm[2]': { label: 'Platform centre of gravity, z (platform frame)', unit: 'mm', factor: 1 },
};

// Units as the analysis writes them → [display unit, factor] (fallback for unknown parameters).
const SUFFIX_UNITS = [
  ['_um_per_m', 'µm/m', 1],
  ['_um_per_h', 'µm/h', 1],
  ['_mm_per_N', 'µm/kN', 1e6],
  ['_um', 'µm', 1],
  ['_mm', 'mm', 1],
  ['_Nm', 'N·m', 1],
  ['_deg', '°', 1],
  ['_ms2', 'ms²', 1],
  ['_ms', 'ms', 1],
  ['_ppm', 'ppm', 1],
  ['_pct', '%', 1],
];

export function parameterWords(name) {
  const n = String(name || '');
  if (PARAMETERS[n]) return PARAMETERS[n];
  let m = n.match(/^error_um\[([^\]]+)\]$/);
  if (m) return { label: `Tool length error (tool of ${m[1]} mm)`, unit: 'µm', factor: 1 };
  for (const [suffix, unit, factor] of SUFFIX_UNITS) {
    if (n.endsWith(suffix)) {
      const words = n.slice(0, -suffix.length).replace(/_/g, ' ');
      return { label: words.charAt(0).toUpperCase() + words.slice(1), unit, factor };
    }
  }
  m = n.replace(/_/g, ' ');
  return { label: m.charAt(0).toUpperCase() + m.slice(1), unit: '', factor: 1 };
}

// "ramp_mm = 2" (an effect variant) → "ramp length 2 mm".
export function variantWords(variant) {
  const v = String(variant || '').trim();
  if (!v) return '';
  // A form with several parts ("ramp_mm = 0.7, t1 fitted"): each part in words.
  if (v.includes(', ')) return v.split(', ').map(variantWords).join(', ');
  if (v === 't1 fitted') return 'load-dependent torque fitted';
  const m = v.match(/^([A-Za-z_][\w[\].]*)\s*=\s*(.+)$/);
  if (!m) return v.replace(/_/g, ' ');
  if (m[1] === 'ramp_mm') return `ramp length ${m[2]} mm`;
  const p = parameterWords(m[1]);
  const value = Number(m[2]);
  const shown = Number.isFinite(value) ? String(Number((value * p.factor).toPrecision(6))) : m[2];
  return `${p.label.charAt(0).toLowerCase()}${p.label.slice(1)} ${shown}${p.unit ? ` ${p.unit}` : ''}`;
}

// Effect words inside a sentence: "joint friction", but "backlash in X".
export function effectInText(effect, variant) {
  const w = effectLabel(effect, variant);
  return `${w.charAt(0).toLowerCase()}${w.slice(1)}`;
}

export function effectLabel(effect, variant) {
  const w = variantWords(variant);
  return w ? `${effectWords(effect)} (${w})` : effectWords(effect);
}

export function um(v) {
  return formatNumber(v, '_um');
}

export function fixedText(v, decimals) {
  let s = v.toFixed(decimals);
  if (/^-0\.?0*$/.test(s)) s = s.slice(1);
  return minus(s);
}

// Value ± standard uncertainty, the uncertainty to two significant digits and the value to the
// same decimal place (GUM 7.2.6); without an uncertainty, four significant digits.
export function valuePm(value, sigma) {
  if (typeof value !== 'number' || !Number.isFinite(value)) return '—';
  if (typeof sigma === 'number' && Number.isFinite(sigma) && sigma > 0) {
    const decimals = Math.min(8, Math.max(0, 1 - Math.floor(Math.log10(sigma))));
    return `${fixedText(value, decimals)} ± ${fixedText(sigma, decimals)}`;
  }
  return plain(value);
}

export function plain(value) {
  if (typeof value !== 'number' || !Number.isFinite(value)) return '—';
  if (value === 0) return '0';
  const abs = Math.abs(value);
  if (abs >= 1e6 || abs < 1e-4) return minus(value.toExponential(3));
  return minus(String(Number(value.toPrecision(4))));
}

// Below this a p-value is only "smaller than": a power of ten beyond the 16 digits a double carries
// tells the reader nothing more (the exact log10 stays in data-log10-p and the JSON).
export const P_FLOOR_LOG10 = -15;

// p-value from its log10 (the F-test p of a strong effect underflows to 0): "1.4 × 10⁻⁸", or
// "< 10⁻¹⁵" for anything smaller.
export function pValueNodes(p, log10p) {
  let lg = typeof log10p === 'number' && Number.isFinite(log10p) ? log10p : null;
  if (lg === null && typeof p === 'number' && p > 0) lg = Math.log10(p);
  if (lg === null) return typeof p === 'number' ? [plain(p)] : ['—'];
  if (lg < P_FLOOR_LOG10) return ['< 10', h('sup', {}, minus(String(P_FLOOR_LOG10)))];
  if (lg >= -3) return [fixedText(10 ** lg, 4)];
  let e = Math.floor(lg);
  let m = 10 ** (lg - e);
  if (m >= 9.95) {
    m = 1;
    e += 1;
  }
  return [`${m.toFixed(1)} × 10`, h('sup', {}, minus(String(e)))];
}

export function pct(v, decimals = 1) {
  return `${fixedText(v, decimals)} %`;
}
