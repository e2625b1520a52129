// The dashboard's shared state: the machines, the selected machine and measurement, the page of
// the measurement list with its filters, and the DBB tests of the machine (for the study forms).

export const PAGE_SIZE = 50;

export const state = {
  machines: [],
  machineId: null,
  measurementId: null,
  // The list shown: one page of the server's answer for the filters.
  list: { items: [], total: 0, offset: 0 },
  filters: { kind: '', test_id: '', from: '', to: '', q: '', order: 'newest' },
  dbb: [], // every DBB test of the machine, oldest first (calibration and discovery forms)
  dbbMachine: null, // the machine state.dbb belongs to
  hexapod: false, // the machine is a hexapod (stored hexapod model, or tests with a tool length)
  selectSeq: 0, // guards against out-of-order responses when clicking quickly
  listSeq: 0,
  pngUrl: null, // object URL of the PNG plot shown in the dialog
  calibChecked: new Set(), // DBB measurement ids ticked in the calibration panel
  jobSeq: 0, // a new job view stops the polling of the previous one
};

// Kinds drawn by the page, by family.
export const FORM_KINDS = ['straightness', 'parallelism', 'flatness'];
// Kinds drawn wide (plot above the figures); they need the stored samples as well.
export const WIDE_KINDS = [...FORM_KINDS, 'tracker', 'servo', 'positioning', 'rotary'];
export const KINDS = ['dbb', 'tracker', 'straightness', 'flatness', 'parallelism', 'positioning'];
