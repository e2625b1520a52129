// The landing view (the address without a view): what kinemetric does, how to start (upload a
// test, look at a machine, set an audit) and the newest activity — uploads, audit verdicts and
// jobs of every machine. An address the page does not know is said here too.

import { api } from './api.js';
import { handleAuth } from './auth.js';
import { $, errorBox, h } from './dom.js';
import { auditWords, formatTimestamp } from './format.js';
import { auditHash, jobHash, machineHash, measurementHash } from './router.js';

function activityList(title, testid, items, item) {
  return h('section', { class: 'activity-block', 'data-testid': testid }, h('h4', {}, title), items.length ? h('ul', { class: 'activity' }, ...items.map((x) => h('li', {}, ...item(x)))) : h('p', { class: 'note' }, 'None yet.'));
}

const isDiscovery = (j) => String(j.kind).includes('discovery');
const jobWords = (j) => (isDiscovery(j) ? 'discovery' : 'calibration');
const jobLink = (j) => (isDiscovery(j) ? `#/discoveries/${j.id}` : jobHash(j.id));
// The machine a job is of: the job's machine_id (its request's stored model, else the machine of
// its DBB tests), else — an answer of an older server — the model its request names.
const jobMachine = (j) => {
  if (typeof j.machine_id === 'string' && j.machine_id) return j.machine_id;
  return j.request && typeof j.request.machine_id === 'string' ? j.request.machine_id : '';
};

// unknown: the address that named nothing (shown as a message), or null.
export async function showHome(unknown = null) {
  const msg = $('#home-unknown');
  msg.hidden = !unknown;
  msg.replaceChildren(...(unknown ? [h('strong', { class: 'problem-title' }, 'Nothing at this address'), h('span', { class: 'problem-detail' }, unknown)] : []));
  const box = $('#home-activity');
  box.setAttribute('aria-busy', 'true');
  try {
    const [meas, audits, jobs] = await Promise.all([api.recentMeasurements(8), api.recentAudits(5).catch(() => ({ audits: [] })), api.jobs(5).catch(() => ({ items: [] }))]);
    box.replaceChildren(
      activityList('Newest uploads', 'home-uploads', meas.items || [], (m) => [h('a', { href: measurementHash(m.id) }, `${m.kind} #${m.id}`), ` ${m.test_id || ''}${m.direction ? ` ${m.direction.toUpperCase()}` : ''} of `, h('a', { href: machineHash(m.machine_id) }, m.machine_id), `, uploaded ${formatTimestamp(m.uploaded_at)}`]),
      activityList('Newest audits', 'home-audits', audits.audits || [], (a) => [h('span', { class: `level-badge level-${a.level}` }, auditWords(a.level)), ' ', h('a', { href: auditHash(a.machine_id) }, a.machine_id), `, ${formatTimestamp(a.created_at)}`]),
      activityList('Newest studies', 'home-jobs', jobs.items || [], (j) => [h('a', { href: jobLink(j) }, `${jobWords(j)} #${j.id}`), ' of ', jobMachine(j) ? h('a', { href: machineHash(jobMachine(j)) }, jobMachine(j)) : 'a machine not recorded', `, ${j.status}, ${formatTimestamp(j.updated_at || j.created_at)}`]),
    );
  } catch (err) {
    if (!handleAuth(err)) box.replaceChildren(errorBox(err));
  } finally {
    box.removeAttribute('aria-busy');
  }
}
