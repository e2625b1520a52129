// Access tokens (#/tokens, admin): every token with its role, state, expiry and last use; making
// one (its secret shown once, to be handed over) and revoking one (the server refuses to revoke
// the last admin without an expiry, and says so); the audit log of who changed what.
// Data attributes: data-token-id on each token's row, data-state (active | expired | revoked).

import { api } from './api.js';
import { handleAuth } from './auth.js';
import { $, asProblem, errorBox, h, problemContent, setMessage } from './dom.js';
import { formatTimestamp, plural } from './format.js';
import { currentRole, refusalContent } from './roles.js';

function tokenRow(t) {
  const revoke =
    t.state === 'active'
      ? h('button', { type: 'button', class: 'secondary small', 'data-testid': 'token-revoke', 'data-token-id': t.id, onclick: () => onRevoke(t) }, 'Revoke')
      : '';
  return h(
    'tr',
    { 'data-token-id': t.id, 'data-state': t.state, 'data-role': t.role },
    h('th', { scope: 'row' }, t.name),
    h('td', {}, t.role),
    h('td', { 'data-key': 'state' }, t.state === 'revoked' ? `revoked ${formatTimestamp(t.revoked_at)}` : t.state),
    h('td', {}, formatTimestamp(t.created_at)),
    h('td', {}, t.expires_at ? formatTimestamp(t.expires_at) : 'never'),
    h('td', { 'data-key': 'last_used' }, t.last_used_at ? formatTimestamp(t.last_used_at) : 'not used yet'),
    h('td', {}, revoke),
  );
}

function tokensTable(items) {
  return h(
    'div',
    { class: 'table-scroll' },
    h(
      'table',
      { class: 'figures tokens-table', 'data-testid': 'tokens-table' },
      h('thead', {}, h('tr', {}, ...['Name', 'Role', 'State', 'Made', 'Expires', 'Last used', ''].map((t) => h('th', { scope: 'col' }, t)))),
      h('tbody', {}, ...items.map(tokenRow)),
    ),
  );
}

function auditLogTable(log) {
  const items = (log && log.items) || [];
  if (!items.length) return h('p', { class: 'note' }, 'Nothing changed yet.');
  return h(
    'div',
    { class: 'table-scroll' },
    h(
      'table',
      { class: 'figures audit-log', 'data-testid': 'audit-log' },
      h('thead', {}, h('tr', {}, ...['When', 'Token', 'Role', 'Request', 'Status', 'Subject'].map((t) => h('th', { scope: 'col' }, t)))),
      h(
        'tbody',
        {},
        ...items.map((e) =>
          h(
            'tr',
            { 'data-log-id': e.id },
            h('td', {}, formatTimestamp(e.at)),
            h('td', {}, e.token_name || (e.token_id === null ? 'no valid token' : `#${e.token_id}`)),
            h('td', {}, e.role || ''),
            h('td', {}, h('code', {}, `${e.method} ${e.path}`)),
            h('td', { class: 'num' }, String(e.status)),
            h('td', {}, e.subject || ''),
          ),
        ),
      ),
    ),
    log.total > items.length ? h('p', { class: 'note' }, `The newest ${items.length} of ${plural(log.total, 'entry', 'entries')}.`) : '',
  );
}

export async function showTokens() {
  const body = $('#tokens-body');
  if (currentRole() && currentRole() !== 'admin') {
    body.replaceChildren();
    $('#audit-log-body').replaceChildren();
    return;
  }
  body.setAttribute('aria-busy', 'true');
  try {
    const [tokens, log] = await Promise.all([api.tokens(), api.auditLog(50)]);
    const items = tokens.items || [];
    $('#tokens-view').dataset.tokens = String(items.length);
    body.replaceChildren(items.length ? tokensTable(items) : h('p', { class: 'note' }, 'No tokens.'));
    $('#audit-log-body').replaceChildren(auditLogTable(log));
  } catch (err) {
    if (!handleAuth(err)) body.replaceChildren(...(refusalContent(err, 'administer tokens') || [errorBox(err)]));
  } finally {
    body.removeAttribute('aria-busy');
  }
}

// The secret with a Copy button: the clipboard where the browser allows it (a secure page),
// else the secret selected for Ctrl+C / long press, and said so.
function secretWithCopy(secret) {
  const code = h('code', { class: 'token-secret', 'data-testid': 'token-secret' }, secret);
  const said = h('span', { class: 'copy-status', 'data-testid': 'token-copy-status', 'aria-live': 'polite' });
  const select = () => {
    const range = document.createRange();
    range.selectNodeContents(code);
    const sel = window.getSelection();
    sel.removeAllRanges();
    sel.addRange(range);
  };
  const copy = async () => {
    try {
      if (!navigator.clipboard?.writeText) throw new Error('no clipboard');
      await navigator.clipboard.writeText(secret);
      said.dataset.copied = 'clipboard';
      said.textContent = 'Copied to the clipboard.';
    } catch {
      select();
      said.dataset.copied = 'selected';
      said.textContent = 'Selected: press Ctrl+C (or Copy) to copy it.';
    }
  };
  return h('span', { class: 'token-secret-line' }, code, h('button', { type: 'button', class: 'secondary small', 'data-testid': 'token-copy', onclick: copy }, 'Copy'), said);
}

async function onCreate(event) {
  event.preventDefault();
  const status = $('#token-create-status');
  const name = $('#token-create-name').value.trim();
  if (!name) {
    $('#token-create-name').setAttribute('aria-invalid', 'true');
    $('#token-create-name').focus();
    setMessage(status, 'error', ...problemContent({ title: 'No token made', detail: 'Give the token a name (who or what uses it).', field: 'name' }));
    return;
  }
  $('#token-create-name').removeAttribute('aria-invalid');
  const body = { name, role: $('#token-create-role').value };
  const expiry = $('#token-create-expiry').value;
  if (expiry) body.expires_in_s = Number(expiry);
  try {
    const made = await api.createToken(body);
    setMessage(
      status,
      'success',
      h('strong', { class: 'problem-title' }, `Token “${made.name}” (${made.role}) made — copy it now, it is not shown again:`),
      secretWithCopy(made.token),
      h('span', {}, made.expires_at ? `It expires ${formatTimestamp(made.expires_at)}.` : 'It does not expire.'),
    );
    $('#token-create-name').value = '';
    await showTokens();
  } catch (err) {
    if (!handleAuth(err)) setMessage(status, 'error', ...(refusalContent(err, 'make tokens') || problemContent(asProblem(err, 'No token made'))));
  }
}

async function onRevoke(t) {
  const status = $('#token-create-status');
  if (!window.confirm(`Revoke the token “${t.name}” (${t.role})? Its next request is refused.`)) return;
  try {
    await api.revokeToken(t.id);
    setMessage(status, 'success', `Token “${t.name}” revoked.`);
    await showTokens();
  } catch (err) {
    if (!handleAuth(err)) setMessage(status, 'error', ...(refusalContent(err, 'revoke tokens') || problemContent(asProblem(err, 'Not revoked'))));
  }
}

export function initTokens() {
  $('#token-create-form').addEventListener('submit', onCreate);
}
