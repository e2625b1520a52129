// The access token box and the messages about it: one status line that never contradicts the
// banner ("token set" only while no request was refused; stale errors cleared).

import { ApiError, getToken } from './api.js';
import { $, h, setMessage } from './dom.js';

let refused = false; // the server refused the stored token (401) since it was set

export function updateTokenStatus() {
  const has = Boolean(getToken());
  const status = $('#token-status');
  status.textContent = !has ? 'No access token' : refused ? 'Token not accepted' : 'Access token set';
  status.classList.toggle('missing', !has || refused);
  status.dataset.state = !has ? 'none' : refused ? 'refused' : 'set';
  $('#token-forget').disabled = !has;
}

// A new token was entered (or forgotten): earlier refusals no longer apply.
export function tokenChanged() {
  refused = false;
  clearAuthProblem();
  updateTokenStatus();
}

export function showAuthProblem(err) {
  const banner = $('#auth-message');
  refused = Boolean(getToken()) && Boolean(err);
  updateTokenStatus();
  const reason = getToken()
    ? 'The server did not accept the access token.'
    : 'An access token is needed to use the dashboard.';
  setMessage(
    banner,
    'error',
    h('strong', {}, 'Access token required (401). '),
    `${reason} Enter your token in the “Access token” box at the top and press “Use token”.`,
    err && err.detail ? h('span', { class: 'problem-detail' }, `Server said: ${err.detail}`) : '',
  );
  $('#token-input').focus();
}

export function clearAuthProblem() {
  if (refused) {
    refused = false;
    updateTokenStatus();
  }
  setMessage($('#auth-message'), null);
}

// Returns true if the error was an auth problem (and has been shown).
export function handleAuth(err) {
  if (err instanceof ApiError && err.status === 401) {
    showAuthProblem(err);
    return true;
  }
  return false;
}
