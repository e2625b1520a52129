// What the discovery page (discovery.js, discovery_result.js) needs from the rest of the
// dashboard (the shell, filled in by app.js); and the address of its start form.

import { shell } from './shell.js';

export const ctx = shell;

export function newFormHash(machineId) {
  return machineId ? `#/discoveries?machine=${encodeURIComponent(machineId)}` : '#/discoveries';
}
