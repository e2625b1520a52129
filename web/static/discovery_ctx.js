// What the discovery page (discovery.js, discovery_result.js) needs from the rest of the
// dashboard, filled in by initDiscovery; and the address of its start form.

export const ctx = {
  getMachineId: () => null,
  getMachines: () => [],
  getMeasurements: () => [],
  handleAuth: () => false,
  selectMachine: async () => {},
  reloadMachines: async () => {},
};

export function newFormHash(machineId) {
  return machineId ? `#/discoveries?machine=${encodeURIComponent(machineId)}` : '#/discoveries';
}
