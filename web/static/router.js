// Addresses of the views, so that a reload keeps the view and a link can be sent to a colleague:
//   #/machines/{machine_id}     a machine and its measurement list
//   #/measurements/{id}         one measurement (its machine's list beside it)
//   #/jobs/{id}                 a calibration job (discovery jobs live at #/discoveries/{id})
//   #/discoveries…              the model-gap discovery page (discovery.js)
//   #/fleet                     every machine: audit level, last measurement, open jobs
//   #/machines/{id}/trends?metric=…   one figure of a machine's results over time, a series per test
//   #/machines/{id}/audit       a machine's accuracy audit: level, rules (editable), findings, history
//   #/tokens                    access tokens and the audit log (admin)
//   (none)                      the landing view: what the product does, how to start, newest activity

export function parseAppRoute(hash = window.location.hash) {
  const s = String(hash || '').replace(/^#/, '');
  let m = s.match(/^\/machines\/([^/?]+)\/trends\/?(?:\?(.*))?$/);
  if (m) return { view: 'trends', machineId: decodeURIComponent(m[1]), metric: new URLSearchParams(m[2] || '').get('metric') };
  if (/^\/fleet\/?$/.test(s)) return { view: 'fleet' };
  if (/^\/tokens\/?$/.test(s)) return { view: 'tokens' };
  m = s.match(/^\/machines\/([^/?]+)\/audit\/?$/);
  if (m) return { view: 'audit', machineId: decodeURIComponent(m[1]) };
  m = s.match(/^\/machines\/([^/?]+)\/?$/);
  if (m) return { view: 'machine', machineId: decodeURIComponent(m[1]) };
  m = s.match(/^\/measurements\/(\d+)\/?$/);
  if (m) return { view: 'measurement', id: Number(m[1]) };
  m = s.match(/^\/jobs\/(\d+)\/?$/);
  if (m) return { view: 'job', jobId: Number(m[1]) };
  if (/^\/discoveries/.test(s)) return { view: 'discovery' };
  if (s === '' || s === '/') return { view: 'home' };
  if (!s.startsWith('/')) return { view: 'anchor' }; // an in-page link (the skip link): no new view
  return { view: 'unknown', address: s };
}

export const machineHash = (id) => `#/machines/${encodeURIComponent(id)}`;
export const measurementHash = (id) => `#/measurements/${id}`;
export const jobHash = (id) => `#/jobs/${id}`;
export const auditHash = (id) => `#/machines/${encodeURIComponent(id)}/audit`;
export const tokensHash = () => '#/tokens';
export const trendsHash = (id, metric) => `#/machines/${encodeURIComponent(id)}/trends${metric ? `?metric=${encodeURIComponent(metric)}` : ''}`;

// Goes to an address (a hashchange follows, which shows the view); the same address again
// shows it again.
export function navigate(hash) {
  if (window.location.hash === hash) window.dispatchEvent(new HashChangeEvent('hashchange'));
  else window.location.hash = hash;
}
