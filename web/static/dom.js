// The DOM helpers of every dashboard module: HTML and SVG element builders, status messages, the
// rendering of an API problem (application/problem+json: title, detail, file, line, field),
// focus kept over a rebuild, downloads of text made in the page.

import { ApiError } from './api.js';
import { parseDecimal } from './format.js';

// h('td', {class: 'num', 'data-key': k, onclick: fn}, child, …): attributes with false / null /
// undefined values are left out, `true` gives an empty attribute, children may be nested arrays.
export function h(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null || v === false) continue;
    if (k === 'class') node.className = v;
    else if (k === 'dataset') Object.assign(node.dataset, v);
    else if (k.startsWith('on')) node.addEventListener(k.slice(2), v);
    else node.setAttribute(k, v === true ? '' : String(v));
  }
  for (const c of children.flat()) {
    if (c === undefined || c === null || c === false) continue;
    node.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
  return node;
}

export function setMessage(node, kind, ...content) {
  node.replaceChildren(...content);
  node.classList.remove('error', 'success', 'info', 'warning');
  node.hidden = content.length === 0;
  if (kind) node.classList.add(kind);
  // Errors are announced immediately; other messages politely.
  node.setAttribute('role', kind === 'error' ? 'alert' : 'status');
}

export function problemContent(err) {
  const parts = [h('strong', { class: 'problem-title' }, err.title || 'Error')];
  if (err.detail) parts.push(h('span', { class: 'problem-detail' }, err.detail));
  const where = [];
  if (err.file) where.push(`file ${err.file}`);
  if (err.line !== undefined && err.line !== null) where.push(`line ${err.line}`);
  if (err.field) where.push(`field “${err.field}”`);
  if (where.length) parts.push(h('span', { class: 'problem-where' }, where.join(', ')));
  return parts;
}

// An API error (or any other) as {title, detail, …} for problemContent: an ApiError or a problem
// the page made ({title, detail, field}) as it is, an Error by its message, a string as it is.
export function asProblem(err, title = 'Error') {
  if (err instanceof ApiError) return err;
  if (err && typeof err === 'object' && !(err instanceof Error) && (err.title || err.detail)) return { title, ...err };
  const detail = err && typeof err.message === 'string' ? err.message : typeof err === 'string' ? err : '';
  return { title, detail: detail || 'something went wrong (no message)' };
}

export function errorBox(err) {
  const box = h('div', { class: 'message error', role: 'alert' });
  box.append(...problemContent(asProblem(err)));
  return box;
}

export const $ = (sel, root = document) => root.querySelector(sel);

const SVG_NS = 'http://www.w3.org/2000/svg';

// el('line', {x1: 0, …}, text?): an SVG element; attributes with null / undefined values are left
// out. r2: a coordinate rounded to 0.01 px.
export function el(name, attrs = {}, text) {
  const node = document.createElementNS(SVG_NS, name);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null) continue;
    node.setAttribute(k, String(v));
  }
  if (text !== undefined) node.textContent = text;
  return node;
}

export const r2 = (v) => Math.round(v * 100) / 100;
export const $$ = (sel, root = document) => [...root.querySelectorAll(sel)];

// Rebuilds the children of `container` with `build()` and keeps the keyboard focus: an element
// that had it (found again by its data-focus-key, else its id) gets it back in the new content.
export function keepFocus(container, build) {
  const active = document.activeElement;
  const inside = active && active !== document.body && container.contains(active);
  const key = inside ? active.dataset.focusKey || (active.id ? `#${active.id}` : null) : null;
  build();
  if (!key) return;
  const again = key.startsWith('#')
    ? container.querySelector(key)
    : container.querySelector(`[data-focus-key="${CSS.escape(key)}"]`);
  if (again) again.focus();
}

// A file download of a blob (a PDF or a table the server made): an <a download> with an object
// URL, revoked once the browser has had time to save it.
export function downloadBlob(blob, filename) {
  const url = URL.createObjectURL(blob);
  const a = h('a', { href: url, download: filename, hidden: true });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 30_000);
}

// A file download of text made in the page (CSV, JSON).
export function downloadText(text, filename, type = 'text/plain') {
  downloadBlob(new Blob([text], { type }), filename);
}

// A finite decimal number written as text: optional sign, digits with at most one '.', an
// optional exponent ("-3.25", "+4", "-1e-3", ".5"; not "1e999", "-Infinity", "0x1").
const DECIMAL = /^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/;

// One CSV cell, safe to open in a spreadsheet (OWASP, CSV injection). The rule: a finite number
// (a JS number, or text that is entirely a finite decimal number such as "-3.25") is written as
// it is, so negative deviations stay numbers. Any other value is text; text beginning with '=',
// '+', '-', '@', tab or CR gets a leading "'", so a spreadsheet shows it instead of running it as
// a formula ("=HYPERLINK(…)" → "'=HYPERLINK(…)"). A cell holding ',', ';', '"', CR or LF is then
// put in double quotes with its quotes doubled (';' too, for spreadsheets that split on it). The
// server's CSV cells follow the same rule (usecases/csv_cell.h).
export function csvCell(v) {
  if (v === undefined || v === null) return '';
  if (typeof v === 'number' && Number.isFinite(v)) return String(v);
  let s = String(v);
  const number = DECIMAL.test(s) && Number.isFinite(Number(s));
  if (!number && /^[=+\-@\t\r]/.test(s)) s = `'${s}`;
  return /[",;\r\n]/.test(s) ? `"${s.replace(/"/g, '""')}"` : s;
}

// CSV of rows (arrays of values): cells by csvCell, "\r\n" line ends (RFC 4180).
export function toCsv(rows) {
  return `${rows.map((r) => r.map(csvCell).join(',')).join('\r\n')}\r\n`;
}

// A numeric form field read by parseDecimal (format.js), the one reader of typed numbers: "5,5" is
// 5.5, "1.234,5" or "abc" are refused. `name` is how messages call the field ("the warn limit");
// min / max bound it, integer asks for a whole number, optional lets it be empty ({empty: true}).
// → {value} | {empty: true} | {error: "sentence beginning with name"}; a refused field is marked
// aria-invalid.
export function readNumberField(input, name, { min, max, integer = false, optional = false } = {}) {
  input.removeAttribute('aria-invalid');
  const r = parseDecimal(input.value);
  let error = r.error ? `${name}: ${r.error}.` : null;
  if (r.empty) error = optional ? null : `${name}: give a number.`;
  else if (!error && integer && !Number.isInteger(r.value)) error = `${name} must be a whole number (not ${input.value.trim()}).`;
  else if (!error && min !== undefined && r.value < min) error = `${name} must be at least ${min} (not ${input.value.trim()}).`;
  else if (!error && max !== undefined && r.value > max) error = `${name} must be at most ${max} (not ${input.value.trim()}).`;
  if (error) {
    input.setAttribute('aria-invalid', 'true');
    return { error };
  }
  return r;
}
