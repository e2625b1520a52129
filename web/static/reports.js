// PDF reports from the server (GET …/report.pdf of a measurement, a job, a machine's audit):
// fetched with the token (a plain link cannot send it) and saved under the server's file name.
// One button on each view: the measurement view, a calibration job, a discovery job, an audit.

import { apiFetchBlob } from './api.js';
import { handleAuth } from './auth.js';
import { $, h, problemContent, asProblem, setMessage } from './dom.js';

async function savePdf(path, filename, status) {
  try {
    const blob = await apiFetchBlob(path, 'application/pdf');
    const url = URL.createObjectURL(blob);
    const a = h('a', { href: url, download: filename, hidden: true });
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 30_000);
    if (status) setMessage(status, 'success', `Report saved as ${filename}.`);
  } catch (err) {
    if (handleAuth(err)) return;
    if (status) setMessage(status, 'error', ...problemContent(asProblem(err, 'No report')));
  }
}

// [button, what it reports: () => [path, filename] or null, where a problem is told]
const BUTTONS = [
  ['#report-pdf', () => {
    const id = $('#detail').dataset.measurementId;
    return id ? [`/api/v1/measurements/${id}/report.pdf`, `kinemetric-measurement-${id}.pdf`] : null;
  }, '#pair-note'],
  ['#job-report-pdf', () => {
    const id = $('#job-view').dataset.jobId;
    return id ? [`/api/v1/jobs/${id}/report.pdf`, `kinemetric-job-${id}.pdf`] : null;
  }, '#job-status'],
  ['#disc-report-pdf', () => {
    const id = $('#discovery').dataset.jobId;
    return id ? [`/api/v1/jobs/${id}/report.pdf`, `kinemetric-job-${id}.pdf`] : null;
  }, '#disc-status'],
  ['#audit-report-pdf', () => {
    const id = $('#audit-view').dataset.machineId;
    return id ? [`/api/v1/machines/${encodeURIComponent(id)}/audit/report.pdf`, `kinemetric-audit-${id.replace(/[^\w.-]/g, '_')}.pdf`] : null;
  }, '#audit-status'],
];

export function initReports() {
  for (const [sel, target, statusSel] of BUTTONS) {
    $(sel).addEventListener('click', () => {
      const t = target();
      if (t) savePdf(t[0], t[1], $(statusSel));
    });
  }
}
