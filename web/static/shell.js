// What a view needs from the dashboard around it, filled in once by app.js: views call these
// instead of importing the modules that import them (no import circles).

export const shell = {
  getMachineId: () => null,
  getMachines: () => [],
  getMeasurements: () => [],
  handleAuth: () => false,
  // Selects a machine in the sidebar (reloading the list when it does not know the machine).
  selectMachine: async () => {},
  reloadMachines: async () => {},
};
