// The Cancel button of a job view (calibration and discovery): shown while the job is queued or
// running, to engineers and admins (data-min-role). DELETE /api/v1/jobs/{id}; the server decides
// who may — the token that submitted the job, or an admin — and a refusal is told in words
// (the title here, the server's reason below it).
// The view's own polling then finds the job cancelled and shows it so.

import { JOB_OPEN } from './contract.js';
import { api, ApiError } from './api.js';
import { handleAuth } from './auth.js';
import { asProblem, h, problemContent, setMessage } from './dom.js';

const OPEN = new Set(JOB_OPEN);
const TITLES = {
  403: 'Not cancelled: only the token that submitted the job, or an admin, may cancel it',
  409: 'Job already finished',
};

// What a job view shows of a cancelled job: by whom (the job's error), and that it has no result.
export function cancelledContent(job) {
  return [
    h('strong', { class: 'problem-title', 'data-testid': 'job-cancelled' }, `Job #${job.id} was cancelled`),
    h('span', { class: 'problem-detail' }, `${job.error ? `${job.error}. ` : ''}No result.`),
  ];
}

// Wires `button` (and the message element `note`) to the job shown: call show(job) with every
// fresh copy of the job. Returns that function.
export function jobCancelControl(button, note) {
  let jobId = null;
  let cancelled = false; // this job, by this page: the button stays hidden
  button.addEventListener('click', async () => {
    if (jobId === null) return;
    const id = jobId;
    button.disabled = true;
    setMessage(note, 'info', `Cancelling job #${id}…`);
    try {
      await api.cancelJob(id);
      if (id !== jobId) return;
      cancelled = true;
      button.hidden = true;
      setMessage(note, null); // the view shows the job cancelled at its next look
    } catch (err) {
      if (id !== jobId) return;
      button.disabled = false;
      if (handleAuth(err)) return;
      const problem = asProblem(err, 'Job not cancelled');
      const status = err instanceof ApiError ? err.status : 0;
      setMessage(note, 'error', ...problemContent({ ...problem, title: TITLES[status] || problem.title }));
    }
  });
  return (job) => {
    if (!job || job.id !== jobId) {
      jobId = job ? job.id : null;
      cancelled = false;
      setMessage(note, null);
      button.disabled = false;
    }
    button.hidden = cancelled || !job || !OPEN.has(job.status);
    button.dataset.jobId = jobId === null ? '' : String(jobId);
  };
}
