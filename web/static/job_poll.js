// The one job poller of the dashboard's job views (calibration and discovery): fetches the job
// every JOB_POLL_MS until it is cancelled, done or failed, or the view has moved on.

import { api } from './api.js';
import { JOB_ENDS } from './contract.js';
import { shell } from './shell.js';

export const JOB_POLL_MS = 500;

// view: { current() → false once another view took over, show(job) → false to stop polling,
//         ended(job) for a job that ended, waiting(job) while it is queued or running,
//         failedToLoad(err) when the job cannot be read }.
export async function pollJob(jobId, view) {
  try {
    for (;;) {
      const job = await api.job(jobId);
      if (!view.current()) return;
      if (view.show(job) === false) return;
      if (JOB_ENDS.includes(job.status)) {
        view.ended(job);
        return;
      }
      view.waiting(job);
      await new Promise((r) => setTimeout(r, JOB_POLL_MS));
      if (!view.current()) return;
    }
  } catch (err) {
    if (view.current()) view.failedToLoad(err);
  }
}

// The machine of a job's tests (for the sidebar after a reload, say): selected when it is not
// the one shown. Errors leave the sidebar as it is; the job is shown anyway.
export async function selectMachineOfJob(job) {
  const id = job.request?.measurement_ids?.[0];
  if (!id) return;
  try {
    const m = await api.measurement(id);
    if (m.machine_id && m.machine_id !== shell.getMachineId()) await shell.selectMachine(m.machine_id);
  } catch {
    // the job is shown anyway
  }
}
