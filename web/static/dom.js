// Small DOM helpers shared by the dashboard modules: element builder, status messages and the
// rendering of an API problem (application/problem+json: title, detail, file, line, field).

import { ApiError } from './api.js';

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

// An API error (or any other) as {title, detail, …} for problemContent.
export function asProblem(err, title = 'Error') {
  return err instanceof ApiError ? err : { title, detail: String((err && err.message) || err) };
}

export function errorBox(err) {
  const box = h('div', { class: 'message error', role: 'alert' });
  box.append(...problemContent(asProblem(err)));
  return box;
}
