// The documented values of the API's fields that the page acts on (docs/formats.md §3.7 and
// "Jobs"): one spelling, here, matching the server's enums (analysis/discovery/engine.h Verdict
// and StopReason; the job queue's statuses and verdicts, server/jobs/jobs.h). Compare with these,
// never with a literal.

// A job's status (GET /api/v1/jobs/{id} `status`).
export const JOB_STATUS = Object.freeze({
  queued: 'queued',
  running: 'running',
  done: 'done',
  failed: 'failed',
  cancelled: 'cancelled',
});
// Statuses a job does not leave.
export const JOB_ENDS = Object.freeze([JOB_STATUS.cancelled, JOB_STATUS.done, JOB_STATUS.failed]);
// Statuses of a job still to finish (it can be cancelled).
export const JOB_OPEN = Object.freeze([JOB_STATUS.queued, JOB_STATUS.running]);

// The server's judgement of a finished job's figures (`verdict`).
export const JOB_VERDICT = Object.freeze({ ok: 'ok', warning: 'warning', failed: 'failed' });

// A discovery's verdict (`verdict` of its result) and why its steps stopped (`stop_code`).
export const DISCOVERY_VERDICT = Object.freeze({ complete: 'complete', misfit: 'model misfit' });
export const STOP_CODE = Object.freeze({
  noiseFloor: 'noise_floor',
  maxSteps: 'max_steps',
  noCandidateLeft: 'no_candidate_left',
  noCandidateQualifies: 'no_candidate_qualifies',
});
