// Thin client for the kinemetricd HTTP API (see the server's /api/v1/openapi.json).
// Every /api/ call carries `Authorization: Bearer <token>`; failures are thrown as ApiError
// built from the server's application/problem+json body (title, detail, file, line, field).

const TOKEN_KEY = 'kinemetric.token';
let memoryToken = '';

export class ApiError extends Error {
  constructor(status, problem) {
    const str = (v) => (typeof v === 'string' ? v : v === undefined || v === null ? '' : JSON.stringify(v));
    const title = str(problem.title) || `HTTP ${status}`;
    const detail = str(problem.detail);
    super(detail ? `${title}: ${detail}` : title);
    this.name = 'ApiError';
    this.status = status;
    this.title = title;
    this.detail = detail;
    this.file = problem.file;
    this.line = problem.line;
    this.field = problem.field;
  }
}

export function getToken() {
  try {
    return localStorage.getItem(TOKEN_KEY) || '';
  } catch {
    return '';
  }
}

export function setToken(token) {
  try {
    if (token) localStorage.setItem(TOKEN_KEY, token);
    else localStorage.removeItem(TOKEN_KEY);
  } catch {
    // Storage may be disabled (private mode); the token then lives for this page only.
  }
  memoryToken = token;
}

function currentToken() {
  return getToken() || memoryToken;
}

// Takes `#token=...` from the URL fragment (if present), stores it and removes it from the
// address bar so it does not linger in history or screenshots. Returns true if one was found.
export function takeTokenFromFragment() {
  const hash = window.location.hash.replace(/^#/, '');
  if (!hash) return false;
  const params = new URLSearchParams(hash);
  const token = params.get('token');
  if (token === null) return false;
  setToken(token.trim());
  params.delete('token');
  const rest = params.toString();
  const url = window.location.pathname + window.location.search + (rest ? `#${rest}` : '');
  window.history.replaceState(null, '', url);
  return true;
}

// The server's refusal as {title, detail, file, line, field}: problem+json as it is; a body
// {"error": {message, file, line, field}} (or {"error": "text"}) read into the same keys, so the
// message is shown in words, never as an object.
function problemOf(body, response) {
  const e = body.error;
  if (e === undefined || body.title || body.detail) return body;
  const fallback = response.statusText || `HTTP ${response.status}`;
  if (typeof e === 'string') return { title: fallback, detail: e };
  if (!e || typeof e !== 'object') return { title: fallback, detail: '' };
  const text = (v) => (v === undefined || v === null ? undefined : typeof v === 'object' ? JSON.stringify(v) : String(v));
  return { title: text(e.title) || fallback, detail: text(e.message ?? e.detail ?? e.reason) || '', file: text(e.file), line: e.line, field: text(e.field) };
}

async function readProblem(response) {
  const text = await response.text();
  try {
    const body = JSON.parse(text);
    if (body && typeof body === 'object' && !Array.isArray(body)) return problemOf(body, response);
  } catch {
    // not JSON: fall through
  }
  return { title: response.statusText || `HTTP ${response.status}`, detail: text.slice(0, 500) };
}

export async function apiFetch(path, { method = 'GET', body, headers = {} } = {}) {
  const allHeaders = { Accept: 'application/json', ...headers };
  const token = currentToken();
  if (token) allHeaders.Authorization = `Bearer ${token}`;
  let response;
  try {
    response = await fetch(path, { method, body, headers: allHeaders, cache: 'no-store' });
  } catch (err) {
    throw new ApiError(0, {
      title: 'Server not reachable',
      detail: `Could not contact the kinemetric server (${err.message}).`,
    });
  }
  if (!response.ok) throw new ApiError(response.status, await readProblem(response));
  if (response.status === 204) return null;
  const text = await response.text();
  return text ? JSON.parse(text) : null;
}

// Binary resources (the PNG plot, PDF reports): an <img src> or a link cannot send the
// Authorization header, so they are fetched here and shown or saved through an object URL.
export async function apiFetchBlob(path, accept = 'image/png') {
  return (await fetchAuthorised(path, accept)).blob();
}

// A GET of `path` with the token; the response when it is ok, else an ApiError of its problem.
async function fetchAuthorised(path, accept) {
  const headers = { Accept: accept };
  const token = currentToken();
  if (token) headers.Authorization = `Bearer ${token}`;
  let response;
  try {
    response = await fetch(path, { headers, cache: 'no-store' });
  } catch (err) {
    throw new ApiError(0, {
      title: 'Server not reachable',
      detail: `Could not contact the kinemetric server (${err.message}).`,
    });
  }
  if (!response.ok) throw new ApiError(response.status, await readProblem(response));
  return response;
}

// A file the server offers for saving (Content-Disposition: attachment; filename="…"):
// {blob, filename}, the name kept to letters, digits, '.', '-' and '_' (else `fallback`).
export async function apiFetchFile(path, fallback, accept = 'text/plain') {
  const response = await fetchAuthorised(path, accept);
  const named = /filename="([\w.-]+)"/.exec(response.headers.get('Content-Disposition') || '');
  return { blob: await response.blob(), filename: named ? named[1] : fallback };
}

export const api = {
  machines: () => apiFetch('/api/v1/machines'),
  // One page of a machine's measurements; filters: kind, test_id, from, to (ISO 8601), q (free
  // text or an id), order (oldest | newest | uploaded). Empty filters are left out.
  measurements: (machineId, { limit = 50, offset = 0, ...filters } = {}) => {
    const q = new URLSearchParams({ machine_id: machineId, limit: String(limit), offset: String(offset) });
    for (const [k, v] of Object.entries(filters)) if (v !== undefined && v !== null && v !== '') q.set(k, String(v));
    return apiFetch(`/api/v1/measurements?${q}`);
  },
  measurement: (id) => apiFetch(`/api/v1/measurements/${encodeURIComponent(id)}`),
  results: (id) => apiFetch(`/api/v1/measurements/${encodeURIComponent(id)}/results`),
  trace: (id) => apiFetch(`/api/v1/measurements/${encodeURIComponent(id)}/trace`),
  // 404 when no opposite-direction test is stored: resolves to null then.
  pair: (id) =>
    apiFetch(`/api/v1/measurements/${encodeURIComponent(id)}/pair`).catch((err) => {
      if (err instanceof ApiError && err.status === 404) return null;
      throw err;
    }),
  // The straightness reversal of a set-up with the other of its pair (404 when that is not stored).
  reversal: (id) => apiFetch(`/api/v1/measurements/${encodeURIComponent(id)}/reversal`),
  // The server's polar plot; at the page's scale (µm a division, divisions each side) when given.
  plotPng: (id, scale = null) => {
    const fixed = scale && scale.umPerDiv > 0 && scale.divisions > 0 ? `?${new URLSearchParams({ um_per_div: String(scale.umPerDiv), divisions: String(scale.divisions) })}` : '';
    return apiFetchBlob(`/api/v1/measurements/${encodeURIComponent(id)}/plot.png${fixed}`);
  },
  // Hexapod calibration study → 202 {job_id}; the job is polled with job(id).
  calibrate: (body) =>
    apiFetch('/api/v1/calibrations', {
      method: 'POST',
      body: JSON.stringify(body),
      headers: { 'Content-Type': 'application/json' },
    }),
  job: (id) => apiFetch(`/api/v1/jobs/${encodeURIComponent(id)}`),
  // Recent background jobs, newest first, without their results.
  jobs: (limit = 200) => apiFetch(`/api/v1/jobs?limit=${encodeURIComponent(String(limit))}`),
  // The jobs (calibrations, discoveries) of one machine, newest first, with their verdicts.
  machineJobs: (machineId, limit = 50) =>
    apiFetch(`/api/v1/jobs?${new URLSearchParams({ machine_id: machineId, limit: String(limit) })}`),
  // Stored machine models (kinemetric-machine/1 documents), versioned.
  // 404 when the machine has no stored model: resolves to null then.
  machineDefinitions: (machineId) =>
    apiFetch(`/api/v1/machines/${encodeURIComponent(machineId)}/definitions`).catch((err) => {
      if (err instanceof ApiError && err.status === 404) return null;
      throw err;
    }),
  // The newest stored model of a machine (the document as stored).
  machineDefinition: (machineId) => apiFetch(`/api/v1/machines/${encodeURIComponent(machineId)}/definition`),
  // Body = the machine JSON text → {machine_id, version, created_at, created}.
  storeMachine: (text, filename) =>
    apiFetch('/api/v1/machines', {
      method: 'POST',
      body: text,
      headers: { 'Content-Type': 'application/json', 'X-Filename': sanitizeFilename(filename || 'machine.json') },
    }),
  // Model-gap discovery study → 202 {job_id}; polled with job(id).
  discover: (body) =>
    apiFetch('/api/v1/discoveries', {
      method: 'POST',
      body: JSON.stringify(body),
      headers: { 'Content-Type': 'application/json' },
    }),
  // The machine a finished calibration / discovery job produced, stored as the next version of
  // its model → {machine_id, version, created_at, created}.
  // Cancels a queued or running job (its owner or an admin) → the job, status cancelled.
  cancelJob: (jobId) => apiFetch(`/api/v1/jobs/${encodeURIComponent(jobId)}`, { method: 'DELETE' }),
  saveJobMachine: (jobId) =>
    apiFetch(`/api/v1/jobs/${encodeURIComponent(jobId)}/save-machine`, {
      method: 'POST',
      body: '{}',
      headers: { 'Content-Type': 'application/json' },
    }),
  // Stored joint-health estimates of a machine, oldest first, with the newest's limits.
  jointHealth: (machineId) => apiFetch(`/api/v1/machines/${encodeURIComponent(machineId)}/joint-health`),
  // Joint resistance and health from stored CW and CCW servo records (stored as an estimate).
  servoJoints: (body) =>
    apiFetch('/api/v1/servo/joints', {
      method: 'POST',
      body: JSON.stringify(body),
      headers: { 'Content-Type': 'application/json' },
    }),
  // Strut forces measured and modelled, and the tool-tip force, of a hexapod servo record.
  servoForce: (id) => apiFetch(`/api/v1/measurements/${encodeURIComponent(id)}/servo/force`),
  // Every machine: newest measurement, open jobs, newest accuracy audit.
  fleet: () => apiFetch('/api/v1/fleet'),
  // The metrics a trend can show, and one metric of a machine's results over time.
  trendMetrics: (machineId) => apiFetch(`/api/v1/machines/${encodeURIComponent(machineId)}/trends`),
  trends: (machineId, metric) =>
    apiFetch(`/api/v1/machines/${encodeURIComponent(machineId)}/trends?${new URLSearchParams({ metric })}`),
  // The machine's audit rules and schedule (404 when none) and its audits, newest first.
  machineAudit: (machineId) => apiFetch(`/api/v1/machines/${encodeURIComponent(machineId)}/audit`),
  audits: (machineId, limit = 100) => apiFetch(`/api/v1/audits?${new URLSearchParams({ machine_id: machineId, limit: String(limit) })}`),
  // Every machine's newest audits (the landing view).
  recentAudits: (limit = 5) => apiFetch(`/api/v1/audits?${new URLSearchParams({ limit: String(limit) })}`),
  // The metrics a rule may name: [{kind, metric, analysis, unit, description, source}].
  auditMetrics: () => apiFetch('/api/v1/audit-metrics'),
  // Replaces the machine's rules and schedule → the stored audit.
  putAudit: (machineId, body) =>
    apiFetch(`/api/v1/machines/${encodeURIComponent(machineId)}/audit`, {
      method: 'PUT',
      body: JSON.stringify(body),
      headers: { 'Content-Type': 'application/json' },
    }),
  // Runs the machine's audit now → the verdict.
  runAudit: (machineId) =>
    apiFetch(`/api/v1/machines/${encodeURIComponent(machineId)}/audit/run`, { method: 'POST', body: '{}', headers: { 'Content-Type': 'application/json' } }),
  // The newest uploads of every machine (the landing view).
  recentMeasurements: (limit = 8) => apiFetch(`/api/v1/measurements?${new URLSearchParams({ limit: String(limit), order: 'uploaded' })}`),
  // Access tokens (admin): list, make (the secret comes back once), revoke; the audit log.
  tokens: () => apiFetch('/api/v1/tokens'),
  createToken: (body) => apiFetch('/api/v1/tokens', { method: 'POST', body: JSON.stringify(body), headers: { 'Content-Type': 'application/json' } }),
  revokeToken: (id) => apiFetch(`/api/v1/tokens/${encodeURIComponent(id)}`, { method: 'DELETE' }),
  auditLog: (limit = 50, offset = 0) => apiFetch(`/api/v1/audit-log?${new URLSearchParams({ limit: String(limit), offset: String(offset) })}`),
  upload: (file, bytes) =>
    apiFetch('/api/v1/measurements', {
      method: 'POST',
      body: bytes,
      headers: { 'Content-Type': 'text/plain', 'X-Filename': sanitizeFilename(file.name) },
    }),
};

// Header values must be ISO-8859-1 without control characters; keep the name readable.
function sanitizeFilename(name) {
  const clean = String(name || 'upload.txt').replace(/[^\x20-\x7e]/g, '_');
  return clean.slice(0, 200) || 'upload.txt';
}
