// Uploads: one or several files at once, chosen or dropped on the panel, each with its own
// outcome (stored as #id with a link, already stored, or the server's reason with file, line
// and field). The last stored file is then shown.

import { api, ApiError } from './api.js';
import { clearAuthProblem, showAuthProblem } from './auth.js';
import { $, h, problemContent, setMessage } from './dom.js';
import { plural } from './format.js';
import { loadMachines, refreshMachine } from './machines.js';
import { refusalContent } from './roles.js';
import { measurementHash, navigate } from './router.js';

async function uploadOne(file) {
  try {
    const res = await api.upload(file, await file.arrayBuffer());
    clearAuthProblem();
    return { file, ok: true, res };
  } catch (err) {
    return { file, ok: false, err };
  }
}

function outcomeItem({ file, ok, res, err }) {
  if (ok) {
    return h(
      'li',
      { class: 'upload-ok', 'data-testid': 'upload-outcome', 'data-outcome': res.created ? 'stored' : 'existing', 'data-measurement-id': res.id },
      `“${file.name}” `,
      res.created ? 'stored as ' : 'was already stored (identical file) as ',
      h('a', { href: measurementHash(res.id) }, `measurement #${res.id}`),
      '.',
    );
  }
  const problem = err instanceof ApiError ? err : { title: 'Upload failed', detail: String(err.message || err) };
  return h('li', { class: 'upload-error', 'data-testid': 'upload-outcome', 'data-outcome': 'refused' }, `“${file.name}”: `, ...(refusalContent(err, 'upload measurements') || problemContent(problem)));
}

export async function uploadFiles(files) {
  const msg = $('#upload-message');
  const button = $('#upload-button');
  if (!files.length) {
    setMessage(msg, 'error', h('strong', { class: 'problem-title' }, 'No file chosen'), h('span', { class: 'problem-detail' }, 'Choose or drop measurement files first.'));
    $('#upload-file').focus();
    return;
  }
  button.disabled = true;
  setMessage(msg, 'info', files.length === 1 ? `Uploading “${files[0].name}”…` : `Uploading ${files.length} files…`);
  const outcomes = [];
  for (const [i, file] of files.entries()) {
    if (files.length > 1) setMessage(msg, 'info', `Uploading ${i + 1} of ${files.length}: “${file.name}”…`);
    outcomes.push(await uploadOne(file));
    if (!outcomes[outcomes.length - 1].ok && outcomes[outcomes.length - 1].err?.status === 401) break;
  }
  button.disabled = false;
  const stored = outcomes.filter((o) => o.ok);
  const refused = outcomes.filter((o) => !o.ok);
  if (refused.some((o) => o.err instanceof ApiError && o.err.status === 401)) {
    showAuthProblem(refused.find((o) => o.err.status === 401).err);
    setMessage(msg, 'error', h('strong', { class: 'problem-title' }, 'Not uploaded'), h('span', { class: 'problem-detail' }, 'An access token is needed (see the message at the top).'));
    return;
  }
  const kind = refused.length ? (stored.length ? 'warning' : 'error') : 'success';
  const single = outcomes.length === 1;
  const summary = single
    ? stored.length
      ? stored[0].res.created
        ? `Uploaded “${stored[0].file.name}” — stored as measurement #${stored[0].res.id}.`
        : `“${stored[0].file.name}” was already stored (identical file) as measurement #${stored[0].res.id}.`
      : null
    : `${stored.length} of ${plural(outcomes.length, 'file')} stored${refused.length ? `, ${refused.length} refused` : ''}.`;
  const parts = [];
  if (summary) parts.push(h('span', { class: 'upload-summary' }, summary));
  if (single && !stored.length) parts.push(...(refusalContent(refused[0].err, 'upload measurements') || problemContent(refused[0].err instanceof ApiError ? refused[0].err : { title: 'Upload failed', detail: String(refused[0].err) })));
  else if (!single) parts.push(h('ul', { class: 'upload-outcomes', 'data-testid': 'upload-outcomes' }, ...outcomes.map(outcomeItem)));
  setMessage(msg, kind, ...parts);
  msg.dataset.stored = String(stored.length);
  msg.dataset.refused = String(refused.length);
  if (stored.length) msg.dataset.measurementId = stored[stored.length - 1].res.id;
  else delete msg.dataset.measurementId;
  if (!stored.length) return;
  $('#upload-form').reset();
  await loadMachines();
  await refreshMachine();
  navigate(measurementHash(stored[stored.length - 1].res.id));
}

export function initUpload() {
  $('#upload-form').addEventListener('submit', (e) => {
    e.preventDefault();
    const input = $('#upload-file');
    uploadFiles([...(input.files || [])]);
  });
  const zone = $('#upload-panel');
  const over = (on) => (e) => {
    e.preventDefault();
    zone.classList.toggle('dragging', on);
  };
  zone.addEventListener('dragenter', over(true));
  zone.addEventListener('dragover', over(true));
  zone.addEventListener('dragleave', over(false));
  zone.addEventListener('drop', (e) => {
    over(false)(e);
    uploadFiles([...(e.dataTransfer?.files || [])]);
  });
}
