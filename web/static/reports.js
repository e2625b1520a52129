// PDF reports from the server (GET …/report.pdf of a measurement, a job, a machine's audit):
// fetched with the token (a plain link cannot send it) and saved under the server's file name.
// One button on each view: the measurement view, a calibration job, a discovery job, an audit.
//
// Every report is a certificate (docs/http.md "Certificates"): beside its button, the number and
// current revision, a draft or approved (by whom, when) from …/report/revisions, asked only once
// the report exists (a loaded measurement, an ended job, an audit with rules); for an engineer an
// "Approve revision N" button (POST …/report/approve {"revision": N}: the revision shown, a newer
// one or an approval that came first answered 409 and said in the block's message box); the
// revisions, each approved one linked to its frozen PDF (?revision=N). On a measurement, the
// "as left" test: one of the later tests of its set-up (same machine, kind, test and direction),
// none by default; the PDF, the state and the approval then name it (?as_left=ID).

import { api, apiFetch, apiFetchBlob } from './api.js';
import { JOB_STATUS } from './contract.js';
import { handleAuth } from './auth.js';
import { $, downloadBlob, h, problemContent, asProblem, setMessage } from './dom.js';
import { formatDirection, formatTimestamp } from './format.js';
import { mayDo, refusalContent } from './roles.js';

async function savePdf(path, filename, status) {
  try {
    downloadBlob(await apiFetchBlob(path, 'application/pdf'), filename);
    if (status) setMessage(status, 'success', `Report saved as ${filename}.`);
  } catch (err) {
    if (handleAuth(err)) return;
    if (status) setMessage(status, 'error', ...problemContent(asProblem(err, 'No report')));
  }
}

// ---------------------------------------------------------------- certificates

// One block a report: where it goes, and what it certifies now (set by show*Certificate).
const CERTS = {
  measurement: { anchor: () => $('#detail > .detail-head'), button: '#report-pdf' },
  job: { anchor: () => $('#job-view > .detail-head'), button: '#job-report-pdf' },
  disc: { anchor: () => $('#disc-report-pdf').parentElement, button: '#disc-report-pdf' },
  audit: { anchor: () => $('#audit-view > .detail-head'), button: '#audit-report-pdf' },
};

function query(asLeft, revision) {
  const q = new URLSearchParams();
  if (asLeft) q.set('as_left', String(asLeft));
  if (revision) q.set('revision', String(revision));
  const s = q.toString();
  return s ? `?${s}` : '';
}

const pdfPath = (c, revision) => `${c.base}/report.pdf${query(c.asLeft, revision)}`;
const pdfName = (c, revision) => `${c.file}${c.asLeft ? `-as-left-${c.asLeft}` : ''}${revision ? `-rev${revision}` : ''}.pdf`;

// The block of a report, made on first use after the view's head (or its button's line).
function cert(key) {
  const c = CERTS[key];
  if (!c.block) makeBlock(key, c);
  return c;
}

function makeBlock(key, c) {
  c.seq = 0;
  c.status = h('div', { class: 'message', 'data-testid': 'certificate-status', 'aria-live': 'polite', hidden: true });
  // One wrapping line (the plot stays within the first screen): the state and Approve, the
  // as-left chooser, the revisions folded.
  c.line = h('span', { 'data-testid': 'certificate-line' });
  c.chooser = h('span', { hidden: true });
  c.count = h('summary', { 'data-testid': 'certificate-revisions-summary' });
  c.list = h('ul', {});
  c.revisions = h('details', { class: 'certificate-revisions', 'data-testid': 'certificate-revisions', hidden: true }, c.count, c.list);
  c.block = h(
    'div',
    { class: 'certificate no-print', id: `certificate-${key}`, 'data-testid': 'certificate', 'data-report': key, hidden: true },
    h('div', { class: 'certificate-line' }, c.line, c.chooser, c.revisions),
    c.status,
  );
  c.anchor().after(c.block);
}

export function hideCertificate(key) {
  const c = cert(key);
  c.seq += 1;
  c.base = null;
  c.block.hidden = true;
  delete $(c.button).dataset.href;
}

// A new subject (or the same one again): shown, its message cleared, its state asked; another
// report's state is not left in view meanwhile.
function begin(c, base, file, approvable) {
  c.seq += 1;
  if (base !== c.base) {
    c.line.replaceChildren();
    c.chooser.hidden = true;
    c.revisions.hidden = true;
    for (const k of ['certificate', 'revision', 'state', 'asLeft']) delete c.block.dataset[k];
  }
  c.base = base;
  c.file = file;
  c.approvable = approvable;
  c.block.hidden = false;
  setMessage(c.status, null);
  $(c.button).dataset.href = pdfPath(c);
  return c.seq;
}

// The measurement view (its item: id, machine_id, kind, test_id, direction, timestamp, …).
export async function showMeasurementCertificate(m) {
  const c = cert('measurement');
  if (c.id !== m.id) c.asLeft = null;
  c.id = m.id;
  const seq = begin(c, `/api/v1/measurements/${m.id}`, `kinemetric-measurement-${m.id}`, true);
  let later = [];
  try {
    later = await laterTests(m);
  } catch (err) {
    if (seq !== c.seq || handleAuth(err)) return;
    setMessage(c.status, 'error', ...problemContent(asProblem(err, 'The later tests of this set-up could not be listed')));
  }
  if (seq !== c.seq) return;
  if (c.asLeft && !later.some((x) => x.id === c.asLeft)) c.asLeft = null;
  renderChooser(c, later);
  await refresh(c);
}

// A calibration ('job') or discovery ('disc') job that ended; approved only when done.
export function showJobCertificate(key, job) {
  const c = cert(key);
  begin(c, `/api/v1/jobs/${job.id}`, `kinemetric-job-${job.id}`, job.status === JOB_STATUS.done);
  refresh(c);
}

export function showAuditCertificate(machineId) {
  const c = cert('audit');
  begin(c, `/api/v1/machines/${encodeURIComponent(machineId)}/audit`, `kinemetric-audit-${machineId.replace(/[^\w.-]/g, '_')}`, true);
  refresh(c);
}

// The tests a measurement's as-left may be: same machine, kind, test and direction, measured
// later (the server's rule), oldest first.
async function laterTests(m) {
  const when = (x) => x.timestamp || x.uploaded_at || '';
  const data = await api.measurements(m.machine_id, { kind: m.kind, test_id: m.test_id, limit: 200, order: 'newest' });
  return (data.items || [])
    .filter((x) => x.id !== m.id && x.kind === m.kind && (x.test_id ?? '') === (m.test_id ?? '') && (x.direction ?? '') === (m.direction ?? '') && when(x) > when(m))
    .sort((a, b) => (when(a) < when(b) ? -1 : when(a) > when(b) ? 1 : a.id - b.id));
}

function renderChooser(c, later) {
  const when = (x) => (x.timestamp ? `measured ${formatTimestamp(x.timestamp)}` : `uploaded ${formatTimestamp(x.uploaded_at)}`);
  const select = h(
    'select',
    {
      id: 'certificate-as-left',
      'data-testid': 'certificate-as-left',
      title: 'The machine as left: a later test of this set-up, for the report’s as-found / as-left section',
      disabled: later.length === 0,
    },
    h('option', { value: '' }, later.length ? 'none' : 'none (no later test of this set-up)'),
    ...later.map((x) => h('option', { value: String(x.id), selected: x.id === c.asLeft, title: x.filename || null }, `#${x.id}${x.direction ? ` ${formatDirection(x.direction)}` : ''}, ${when(x)}`)),
  );
  select.addEventListener('change', () => {
    c.asLeft = select.value ? Number(select.value) : null;
    c.line.replaceChildren(); // another certificate: nothing of the previous one to approve
    c.revisions.hidden = true;
    begin(c, c.base, c.file, c.approvable);
    refresh(c);
  });
  c.chooser.hidden = false;
  c.chooser.replaceChildren(h('label', { for: 'certificate-as-left' }, 'As left'), select);
}

// Asks the certificate's revisions and shows them (the message box kept as it is).
async function refresh(c) {
  const seq = c.seq;
  const base = c.base;
  c.block.setAttribute('aria-busy', 'true');
  try {
    const data = await apiFetch(`${base}/report/revisions${query(c.asLeft)}`);
    if (seq !== c.seq) return;
    render(c, data);
  } catch (err) {
    if (seq !== c.seq || handleAuth(err)) return;
    c.line.replaceChildren();
    c.revisions.hidden = true;
    setMessage(c.status, 'error', ...problemContent(asProblem(err, 'The certificate could not be read')));
  } finally {
    if (seq === c.seq) c.block.removeAttribute('aria-busy');
  }
}

const approval = (r) => `approved by ${r.approved_by} at ${formatTimestamp(r.approved_at, { seconds: true })}`;

function render(c, data) {
  const revisions = Array.isArray(data.revisions) ? data.revisions : [];
  const n = data.current_revision;
  const current = revisions.find((r) => r.revision === n) || { revision: n };
  const approved = Boolean(current.approved_by);
  Object.assign(c.block.dataset, { certificate: data.certificate, revision: String(n), state: approved ? 'approved' : 'draft', asLeft: c.asLeft ? String(c.asLeft) : '' });
  const approve =
    !approved && c.approvable && mayDo('engineer')
      ? h('button', { type: 'button', class: 'secondary small', 'data-testid': 'certificate-approve', 'data-min-role': 'engineer', 'data-revision': String(n) }, `Approve revision ${n}`)
      : '';
  if (approve) approve.addEventListener('click', () => approveRevision(c, n, approve));
  c.line.replaceChildren(
    h('strong', {}, 'Certificate '),
    h('span', { 'data-testid': 'certificate-state' }, `${data.certificate} rev ${n} — ${approved ? approval(current) : 'draft'}`),
    approve,
  );
  const approvedCount = revisions.filter((r) => r.approved_by).length;
  c.revisions.hidden = revisions.length === 0;
  c.count.textContent = `Revisions: ${revisions.length}${approvedCount ? `, ${approvedCount} approved` : ''}`;
  c.list.replaceChildren(
    ...[...revisions].reverse().map((r) =>
      h(
        'li',
        { 'data-revision': String(r.revision), 'data-state': r.approved_by ? 'approved' : 'draft' },
        `rev ${r.revision} of ${formatTimestamp(r.created_at)}${r.revision === n ? ' (current)' : ''} — ${r.approved_by ? approval(r) : 'draft, not approved'}`,
        r.approved_by ? [' · ', revisionLink(c, r.revision)] : '',
      ),
    ),
  );
}

function revisionLink(c, revision) {
  const path = pdfPath(c, revision);
  const name = pdfName(c, revision);
  const a = h('a', { href: path, download: name, 'data-testid': 'certificate-revision-pdf', 'data-revision': String(revision) }, `PDF of rev ${revision}`);
  a.addEventListener('click', (e) => {
    e.preventDefault(); // the link cannot send the token: fetched here
    savePdf(path, name, c.status);
  });
  return a;
}

async function approveRevision(c, revision, button) {
  const seq = c.seq;
  button.disabled = true;
  try {
    const r = await apiFetch(`${c.base}/report/approve${query(c.asLeft)}`, {
      method: 'POST',
      body: JSON.stringify({ revision }),
      headers: { 'Content-Type': 'application/json' },
    });
    if (seq !== c.seq) return;
    setMessage(c.status, 'success', `${r.certificate} revision ${r.revision} ${approval(r)}.`);
  } catch (err) {
    if (seq !== c.seq || handleAuth(err)) return;
    setMessage(c.status, 'error', ...(refusalContent(err, 'approve reports') || problemContent(asProblem(err, 'Not approved'))));
  }
  await refresh(c); // the state as it is now (a newer revision, or who approved first)
}

// ---------------------------------------------------------------- the PDF buttons

// [button, what it reports: () => [path, filename] or null, where a problem is told]
const BUTTONS = [
  ['#report-pdf', () => {
    const id = $('#detail').dataset.measurementId;
    const c = cert('measurement');
    if (!id) return null;
    return c.base && String(c.id) === id ? [pdfPath(c), pdfName(c)] : [`/api/v1/measurements/${id}/report.pdf`, `kinemetric-measurement-${id}.pdf`];
  }, () => cert('measurement').status],
  ['#job-report-pdf', () => {
    const id = $('#job-view').dataset.jobId;
    return id ? [`/api/v1/jobs/${id}/report.pdf`, `kinemetric-job-${id}.pdf`] : null;
  }, () => $('#job-status')],
  ['#disc-report-pdf', () => {
    const id = $('#discovery').dataset.jobId;
    return id ? [`/api/v1/jobs/${id}/report.pdf`, `kinemetric-job-${id}.pdf`] : null;
  }, () => $('#disc-status')],
  ['#audit-report-pdf', () => {
    const id = $('#audit-view').dataset.machineId;
    return id ? [`/api/v1/machines/${encodeURIComponent(id)}/audit/report.pdf`, `kinemetric-audit-${id.replace(/[^\w.-]/g, '_')}.pdf`] : null;
  }, () => $('#audit-status')],
];

export function initReports() {
  for (const key of Object.keys(CERTS)) cert(key);
  for (const [sel, target, status] of BUTTONS) {
    $(sel).addEventListener('click', () => {
      const t = target();
      if (t) savePdf(t[0], t[1], status());
    });
  }
}
