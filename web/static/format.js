// Number and label formatting for the dashboard. Units follow the key suffix convention of
// the project (docs/formats.md §3): _um → µm (3 decimals), _mm → mm, _deg → °, _pct → %.

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
  turn_start_deg: 'Evaluated turn start',
  turn_end_deg: 'Evaluated turn end',
  min_zone_centre_um: 'Minimum-zone centre',
  radial_error_range_um: 'Radial error range',
  machine_centre_error_um: 'Machine centre error',
  circular_hysteresis_um: 'Circular hysteresis H (ISO 230-4, about the common centre)',
  circular_hysteresis_own_centres_um: 'Circular hysteresis about each trace’s own centre',
  bidirectional_circular_deviation_um: 'Bidirectional circular deviation G(b) (ISO 230-4)',
  straightness_lsq_um: 'Straightness (least-squares line)',
  straightness_min_zone_um: 'Straightness (minimum zone)',
  straightness_end_point_um: 'Straightness (end-point line)',
  slope_um_per_m: 'Slope (least-squares line)',
  intercept_um: 'Least-squares line at 0 mm',
  min_zone_slope_um_per_m: 'Slope of the minimum-zone lines',
  end_point_slope_um_per_m: 'Slope of the end-point line',
  slope_with_periodic_um_per_m: 'Slope (fitted with the periodic terms)',
  flatness_lsq_um: 'Flatness (least-squares plane)',
  flatness_min_zone_um: 'Flatness (minimum zone)',
  range_um: 'Range of readings (from the datum)',
  parallelism_um: 'Parallelism (to the datum)',
  points: 'Points',
  length_mm: 'Length of travel',
  period_mm: 'Period',
  amplitude_um: 'Amplitude',
  phase_deg: 'Phase',
  false_alarm_probability: 'False-alarm probability',
  order: 'Order',
  residual_rms_um: 'Residual RMS',
  condition_number: 'Condition number',
  rejected_readings_count: 'Rejected readings',
  sigma_um: 'Reading noise σ',
  readings_used: 'Readings used',
  unknowns: 'Unknowns',
  iterations: 'Iterations',
  // Laser positioning (ISO 230-2): the letters of the standard after the words.
  axis: 'Axis',
  accuracy_um: 'Accuracy A',
  reversal_value_um: 'Reversal value B',
  systematic_deviation_um: 'Systematic positioning error E',
  mean_deviation_range_um: 'Range of the mean bidirectional deviation M',
  repeatability_um: 'Repeatability R',
  accuracy_up_um: 'Accuracy A↑ (towards +)',
  accuracy_down_um: 'Accuracy A↓ (towards −)',
  repeatability_up_um: 'Repeatability R↑ (towards +)',
  repeatability_down_um: 'Repeatability R↓ (towards −)',
  systematic_deviation_up_um: 'Systematic positioning error E↑ (towards +)',
  systematic_deviation_down_um: 'Systematic positioning error E↓ (towards −)',
  mean_reversal_value_um: 'Mean reversal value B̄',
  iso230_2_compliant: 'ISO 230-2 compliant',
  runs: 'Runs',
  target_count: 'Targets',
  readings: 'Readings',
  cycle: 'Cycle',
  timestamp: 'Measured at',
};

// Dotted keys (nested objects of the results) whose label is not "parent: leaf".
const FULL_LABELS = {
  'plane.slope_x_um_per_m': 'Least-squares plane: slope in X',
  'plane.slope_y_um_per_m': 'Least-squares plane: slope in Y',
  'plane.offset_um': 'Least-squares plane: height at x = y = 0',
  'min_zone_plane.slope_x_um_per_m': 'Minimum-zone plane: slope in X',
  'min_zone_plane.slope_y_um_per_m': 'Minimum-zone plane: slope in Y',
  'min_zone_plane.offset_um': 'Minimum-zone plane: height at x = y = 0',
  'vdi3441.P_um': 'VDI 3441 P (position uncertainty)',
  'vdi3441.Pa_um': 'VDI 3441 Pa (positional deviation)',
  'vdi3441.Ps_um': 'VDI 3441 Ps (positional scatter)',
  'vdi3441.U_um': 'VDI 3441 U (reversal span)',
};

export function fullLabelOf(key) {
  return FULL_LABELS[key] || null;
}

// Effect names of docs/formats.md §4 in words (the axis letter, if any, is appended).
const EFFECT_WORDS = {
  centre_offset: 'Centre offset (set-up)',
  radius_error: 'Radius error',
  servo_lag: 'Servo lag',
  servo_mismatch: 'Servo gain mismatch',
  squareness: 'Squareness error',
  scale_mismatch: 'Scale mismatch',
  backlash: 'Backlash',
  reversal_spike: 'Reversal spike',
  lateral_play: 'Lateral play',
  cyclic_error: 'Cyclic error',
  straightness: 'Straightness error',
  stick_slip: 'Stick-slip',
  kinematic_parameters: 'Kinematic parameters',
  gravity_deflection: 'Gravity deflection',
  joint_friction: 'Joint friction',
  tool_length_error: 'Tool length error',
  thermal_drift: 'Thermal drift',
};

// "backlash_x" → "Backlash in X"; unknown names are shown as they are.
export function effectWords(name) {
  const s = String(name || '');
  if (EFFECT_WORDS[s]) return EFFECT_WORDS[s];
  const m = s.match(/^(.*)_([a-z])$/);
  if (m && EFFECT_WORDS[m[1]]) return `${EFFECT_WORDS[m[1]]} in ${m[2].toUpperCase()}`;
  return s.replace(/_/g, ' ');
}

// Units as the analysis writes them ("um", "um/m", "ppm", "ms") → display text.
export function displayUnit(u) {
  const map = { um: 'µm', 'um/m': 'µm/m', ppm: 'ppm', ms: 'ms', deg: '°', mm: 'mm' };
  return map[u] ?? String(u || '');
}

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

// A standard uncertainty with two significant digits in plain notation ("0.00035", "0.12",
// "1500"): small values keep their digits instead of rounding to "0.000".
export function formatUncertainty(value) {
  if (typeof value !== 'number' || !Number.isFinite(value)) return '—';
  if (value === 0) return '0';
  const rounded = Number(Math.abs(value).toPrecision(2));
  const decimals = Math.max(0, 1 - Math.floor(Math.log10(rounded)));
  return fixed(Math.sign(value) * rounded, Math.min(decimals, 12));
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

// A count with its noun in the right number: plural(1, 'gap') → "1 gap", plural(3, 'gap') →
// "3 gaps", plural(2, 'entry', 'entries'); `text` writes the number (e.g. with thin spaces).
export function plural(n, one, many = `${one}s`, text = String) {
  return `${text(n)} ${Number(n) === 1 ? one : many}`;
}

// Every time the page shows, in UTC and saying so, as the PDF reports print them:
// "2026-12-06 08:18 UTC". {seconds: true} adds the seconds ("08:18:05 UTC"); {zone: false} leaves
// the zone out where a heading of the list already says "UTC".
export function formatTimestamp(ts, { seconds = false, zone = true } = {}) {
  if (ts === undefined || ts === null || ts === '') return '';
  const d = ts instanceof Date ? ts : new Date(ts);
  if (Number.isNaN(d.getTime())) return String(ts);
  const iso = d.toISOString(); // always UTC: 2026-12-06T08:18:05.000Z
  const time = `${iso.slice(0, 10)} ${iso.slice(11, seconds ? 19 : 16)}`;
  return zone ? `${time} UTC` : time;
}

// A number typed in a form field, read one way everywhere on the page: "5.5", " 5.5 ", "5,5" (a
// decimal comma), "-1,25e-3", ".5". Anything else is refused, never guessed: thousands separators
// ("1.234,5", "1 000", "12,500": a comma before exactly three digits may be either), two
// separators ("5,5,5"), letters, "Infinity". → {value} | {empty: true} | {error: "reason"}.
const TYPED_NUMBER = /^[+-]?(\d+([.,]\d*)?|[.,]\d+)([eE][+-]?\d+)?$/;
export function parseDecimal(text) {
  const s = String(text ?? '').trim();
  if (s === '') return { empty: true };
  if (!TYPED_NUMBER.test(s)) return { error: `“${s}” is not a number (write it as 5.5 or 5,5, without thousands separators)` };
  if (/^[+-]?[1-9]\d{0,2},\d{3}(?![\deE])/.test(s)) return { error: `“${s}” is ambiguous: a comma before three digits may separate thousands (write ${s.replace(',', '')} or ${s.replace(',', '.')})` };
  const value = Number(s.replace(',', '.'));
  if (!Number.isFinite(value)) return { error: `“${s}” is not a finite number` };
  return { value };
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

// The level of an accuracy audit in words, as the API documents the levels.
const AUDIT_WORDS = { 1: 'level 1 — normal', 2: 'level 2 — warn', 3: 'level 3 — stop' };
export const auditWords = (level) => AUDIT_WORDS[level] || `level ${level}`;
