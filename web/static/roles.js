// The role of the presented token (GET /api/v1/whoami) and what it may do: controls marked
// data-min-role="operator|engineer|admin" are hidden for a lower role (style.css, by the role
// on <body>), and a refusal (403) is told in words naming the role and the action.

import { ApiError, apiFetch } from './api.js';
import { $, h } from './dom.js';

const RANK = { viewer: 1, operator: 2, engineer: 3, admin: 4 };
let role = null;

export const currentRole = () => role;
export const mayDo = (minRole) => !role || (RANK[role] || 0) >= (RANK[minRole] || 0);

// Asks the server; on failure (no token yet, 401) the controls stay as they are.
export async function loadRole() {
  try {
    const me = await apiFetch('/api/v1/whoami');
    role = me.role;
    document.body.dataset.role = role;
    $('#role-status').textContent = `${me.name} · role ${role}`;
  } catch {
    role = null;
    delete document.body.dataset.role;
    $('#role-status').textContent = '';
  }
}

export function forgetRole() {
  role = null;
  delete document.body.dataset.role;
  $('#role-status').textContent = '';
}

// A 403 as one sentence: "Your role (viewer) may not upload measurements." and the server's
// reason; null for any other error.
export function refusalContent(err, action) {
  if (!(err instanceof ApiError) || err.status !== 403) return null;
  return [
    h('strong', { class: 'problem-title', 'data-testid': 'role-refusal' }, `Your role (${role || 'unknown'}) may not ${action}.`),
    err.detail ? h('span', { class: 'problem-detail' }, `Server said: ${err.detail}`) : '',
  ];
}
