// Number and label formatting for the dashboard. Units follow the key suffix convention of
// the project (contract §3): _um → µm (3 decimals), _mm → mm, _deg → °, _pct → %.

const UNITS = [
  ['_um_per_m', 'µm/m', 3],
  ['_um', 'µm', 3],
  ['_mm_min', 'mm/min', 0],
  ['_mm', 'mm', 4],
  ['_deg', '°', 1],
  ['_rad', 'rad', 5],
  ['_pct', '%', 1],
  ['_s', 's', 3],
  ['_c', '°C', 2],
];

const LABELS = {
  test_id: 'Test',
  direction: 'Direction',
  mode: 'Evaluation mode',
  centre_offset_x_um: 'Centre offset X',
  centre_offset_y_um: 'Centre offset Y',
  average_radial_error_um: 'Average radial error',
  circularity_um: 'Circularity',
  min_zone_circularity_um: 'Circularity (minimum zone)',
  analysis_version: 'Analysis version',
  evaluated_turn_deg: 'Evaluated turn',
  circular_deviation_um: 'Circular deviation G (ISO 230-4)',
  radial_deviation_max_um: 'Radial deviation F max (ISO 230-4)',
  radial_deviation_min_um: 'Radial deviation F min (ISO 230-4)',
  sample_count: 'Samples',
  fit_rms_um: 'Fit residual RMS',
  fitted_radius_mm: 'Fitted radius',
  radius_mm: 'Commanded radius',
  bar_length_mm: 'Bar length',
  plane: 'Plane',
};

const MODE_LABELS = {
  centre_corrected: 'centre corrected',
  absolute: 'absolute (jig)',
};

export function unitOf(key) {
  for (const [suffix, unit, decimals] of UNITS) {
    if (key.endsWith(suffix)) return { unit, decimals, stem: key.slice(0, -suffix.length) };
  }
  return { unit: '', decimals: null, stem: key };
}

// "min_zone_circularity_um" → "Min zone circularity" (unit shown separately).
export function labelOf(key) {
  const leaf = key.split('.').pop();
  if (LABELS[leaf]) return LABELS[leaf];
  const { stem } = unitOf(leaf);
  const words = stem.replace(/_/g, ' ').trim();
  return words.charAt(0).toUpperCase() + words.slice(1);
}

export function formatNumber(value, key = '') {
  if (typeof value !== 'number' || !Number.isFinite(value)) return '—';
  const { decimals } = unitOf(key);
  if (decimals !== null) return fixed(value, decimals);
  if (Number.isInteger(value)) return String(value);
  const abs = Math.abs(value);
  if (abs !== 0 && (abs < 1e-3 || abs >= 1e6)) return value.toExponential(3).replace('-', '−');
  return fixed(value, 4);
}

function fixed(value, decimals) {
  // Avoid "-0.000" and use a true minus sign for readability.
  let s = value.toFixed(decimals);
  if (/^-0\.?0*$/.test(s)) s = s.slice(1);
  return s.replace('-', '−');
}

export function formatDirection(d) {
  return d ? String(d).toUpperCase() : '—';
}

export function formatMode(m) {
  return MODE_LABELS[m] || (m ? String(m) : '—');
}

export function formatTimestamp(ts) {
  if (!ts) return '';
  const d = new Date(ts);
  if (Number.isNaN(d.getTime())) return String(ts);
  // ISO-like, local time, minutes resolution: readable and unambiguous on the shop floor.
  const pad = (n) => String(n).padStart(2, '0');
  return `${d.getFullYear()}-${pad(d.getMonth() + 1)}-${pad(d.getDate())} ${pad(d.getHours())}:${pad(d.getMinutes())}`;
}

// "Nice" step ≥ x from the 1-2-5 series (used for the µm/div scale of the polar plot).
export function niceStep(x) {
  if (!(x > 0) || !Number.isFinite(x)) return 1;
  const exp = Math.floor(Math.log10(x));
  const base = 10 ** exp;
  for (const m of [1, 2, 5, 10]) {
    if (m * base >= x * (1 - 1e-9)) return m * base;
  }
  return 10 * base;
}

export function formatStep(step) {
  // 0.5, 1, 2, 5, 10, ... without trailing zeros
  return String(Number(step.toPrecision(6)));
}
