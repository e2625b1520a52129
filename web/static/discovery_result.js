// The result of a model-gap discovery job (the JSON of `kinemetric discover --json`,
// usecases/discovery_json.cpp): verdict, summary, the steps with their evidence, the gap shrinking
// step by step down to the noise floor, the candidates, the gap of every test, the final model
// with its uncertainties, the compensation preview ([PM-600 report] table 4.5), saving the
// updated machine and the result JSON. A failed job: its reason and nothing else.

import { api } from './api.js';
import { DISCOVERY_VERDICT } from './contract.js';
import { renderGapChart } from './discovery_chart.js';
import { $, asProblem, h, problemContent, setMessage } from './dom.js';
import { ctx, newFormHash } from './discovery_ctx.js';
import { effectInText, effectLabel, fixedText, pValueNodes, parameterWords, pct, plain, um, valuePm, variantWords } from './discovery_words.js';
import { displayUnit, effectWords, formatDirection, plural } from './format.js';

const result = { jsonUrl: null }; // object URL of the result JSON offered for download

export function renderFailed(job) {
  const banner = h(
    'div',
    { class: 'verdict verdict-failed', role: 'alert', 'data-testid': 'disc-verdict', 'data-verdict': 'failed' },
    h('strong', { class: 'verdict-title' }, 'Discovery failed'),
    h('span', { class: 'verdict-detail problem-detail', 'data-testid': 'disc-error' }, job.error || 'no reason given'),
    h('span', { class: 'verdict-detail' }, 'No model and no figures: the study did not finish. Check the chosen tests and the machine model, then start it again.'),
  );
  $('#disc-result').replaceChildren(banner, actionsBox(job, null));
}

// ---------------------------------------------------------------- result

function verdictBanner(r) {
  const complete = r.verdict === DISCOVERY_VERDICT.complete;
  const misfit = r.verdict === DISCOVERY_VERDICT.misfit;
  const figures = `Unexplained gap ${um(r.unexplained_rms_um)} µm RMS; noise floor ${um(r.noise_floor_um)} µm.`;
  const title = complete ? 'Complete' : misfit ? 'Model misfit' : `Verdict: ${r.verdict || 'none'}`;
  const say = complete
    ? 'The model with the effects found explains the tests down to the measurement noise.'
    : misfit
      ? 'The tests show an error that none of the candidate effects describes: the fitted values below are provisional.'
      : 'The study gave no clear verdict.';
  return h(
    'div',
    {
      class: `verdict ${complete ? 'verdict-complete' : misfit ? 'verdict-misfit' : 'verdict-unclear'}`,
      role: 'status',
      'data-testid': 'disc-verdict',
      'data-verdict': r.verdict || '',
    },
    h('strong', { class: 'verdict-title' }, title),
    h('span', { class: 'verdict-detail' }, say),
    h('span', { class: 'verdict-detail', 'data-testid': 'disc-stop-reason' }, `Stopped because ${r.stop_reason || 'no reason was given'}. ${figures}`),
    typeof r.repeatability_floor_um === 'number' && r.repeatability_floor_um > 0
      ? h('span', { class: 'verdict-detail', 'data-testid': 'disc-repeatability' }, `What the CW and CCW runs of a test do not share (noise, coloured noise included): ${um(r.repeatability_floor_um)} µm.`)
      : null,
    misfit && r.misfit?.sentence ? h('span', { class: 'verdict-detail', 'data-testid': 'disc-misfit' }, sentenceWords(r.misfit.sentence)) : null,
  );
}

function summaryList(job, r) {
  const req = job.request || {};
  const base = baseGap(r);
  const items = [
    ['Machine', r.kind === 'hexapod' ? `hexapod ${r.machine_id || req.machine_id || ''}`.trim() : `serial${r.plane ? ` (${r.plane} plane)` : ''}`],
    ['Model', req.machine_id ? `${req.machine_id} version ${req.machine_version ?? '?'}` : 'none'],
    ['DBB tests', String((req.measurement_ids || []).length)],
    r.method ? ['Method', String(r.method).replace(/[-_]/g, ' ')] : null,
    ['Gap of the base model', `${um(base)} µm RMS`],
    ['Unexplained', `${um(r.unexplained_rms_um)} µm RMS`],
    ['Noise floor', `${um(r.noise_floor_um)} µm`],
    typeof r.condition_number === 'number' ? ['Condition number', plain(r.condition_number)] : null,
  ].filter(Boolean);
  return h(
    'dl',
    { class: 'disc-summary', 'data-testid': 'disc-summary' },
    ...items.map(([k, v]) => h('div', {}, h('dt', {}, k), h('dd', { 'data-key': k }, v))),
  );
}

function baseGap(r) {
  if (typeof r.base?.gap_rms_um === 'number') return r.base.gap_rms_um;
  if (Array.isArray(r.steps) && r.steps.length) return r.steps[0].gap_rms_before_um;
  return r.unexplained_rms_um;
}

function heldOut(ev) {
  const b = ev?.cv_press_before_um2;
  const a = ev?.cv_press_after_um2;
  if (typeof b !== 'number' || typeof a !== 'number' || !(b > 0)) return null;
  return { before: b, after: a, pct: 100 * (1 - a / b) };
}

// The analysis' sentence with its names in words: "(ramp_mm = 2)" → "(ramp length 2 mm)",
// "the fitted joint_friction" → "the fitted joint friction".
export function sentenceWords(text) {
  return String(text || '')
    .replace(/\b([A-Za-z][A-Za-z0-9]*(?:_[A-Za-z0-9]+)+)\s*=\s*(-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?)/g, (_, n, v) => variantWords(`${n} = ${v}`))
    .replace(/\b([a-z][a-z0-9]*(?:_[a-z0-9]+)+)\b/g, (n) => effectInText(n));
}

// Serial steps carry no sentence: the fitted value and the runner-up say what was found.
function evidenceText(step) {
  const ev = step.evidence || {};
  if (ev.sentence) return sentenceWords(ev.sentence);
  const parts = [];
  if (ev.value !== undefined) {
    const v = Array.isArray(ev.value)
      ? ev.value.map((x, i) => valuePm(x, Array.isArray(ev.sigma) ? ev.sigma[i] : ev.sigma)).join(', ')
      : valuePm(ev.value, ev.sigma);
    parts.push(`Fitted ${v}${ev.unit ? ` ${displayUnit(ev.unit)}` : ''}${typeof ev.z_score === 'number' ? ` (${fixedText(ev.z_score, 1)} σ from zero)` : ''}.`);
  }
  if (ev.runner_up) parts.push(`Next best candidate: ${effectWords(ev.runner_up)}.`);
  if (Array.isArray(ev.indistinguishable_from) && ev.indistinguishable_from.length) {
    parts.push(`Not distinguishable from ${ev.indistinguishable_from.map(effectWords).join(', ')}.`);
  }
  return parts.join(' ') || '—';
}

function stepsTable(r) {
  const steps = Array.isArray(r.steps) ? r.steps : [];
  const body = h('tbody');
  if (!steps.length) {
    body.append(h('tr', {}, h('td', { colspan: 6, class: 'text-left' }, 'No effect was added: the base model already explains the tests as well as any candidate.')));
  }
  steps.forEach((s, i) => {
    const ev = s.evidence || {};
    const ho = heldOut(ev);
    body.append(
      h(
        'tr',
        { 'data-step': i + 1, 'data-effect': s.added_effect },
        h('td', { class: 'num', 'data-key': 'step', 'data-label': 'Step' }, String(i + 1)),
        h('th', { scope: 'row', 'data-key': 'effect', 'data-step': i + 1 }, effectLabel(s.added_effect, ev.variant)),
        h(
          'td',
          { class: 'num', 'data-key': 'gap', 'data-label': 'Gap RMS (µm)' },
          h('span', { 'data-key': 'gap_rms_before_um' }, um(s.gap_rms_before_um)),
          ' → ',
          h('span', { 'data-key': 'gap_rms_after_um' }, um(s.gap_rms_after_um)),
        ),
        h('td', { class: 'evidence', 'data-key': 'sentence' }, evidenceText(s)),
        h('td', { class: 'num', 'data-key': 'p_value', 'data-label': 'p-value', 'data-log10-p': ev.log10_p_value ?? '' }, ...pValueNodes(ev.p_value, ev.log10_p_value)),
        h(
          'td',
          { class: 'num', 'data-key': 'held_out', 'data-label': 'Held-out prediction error', 'data-pct': ho ? ho.pct : '' },
          ho
            ? [
                h('span', { class: 'held-out-pct' }, `${ho.pct >= 0 ? '−' : '+'}${pct(Math.abs(ho.pct))}`),
                h('span', { class: 'held-out-press' }, `${plain(ho.before)} → ${plain(ho.after)} µm²`),
              ]
            : h('span', { title: 'the serial study does not score held-out tests' }, '—'),
        ),
      ),
    );
  });
  return h(
    'table',
    { class: 'figures small disc-steps stack-narrow', 'data-testid': 'disc-steps' },
    h('caption', {}, 'Steps: the effect added at each step and why'),
    h(
      'thead',
      {},
      h(
        'tr',
        {},
        h('th', { scope: 'col', class: 'num' }, 'Step'),
        h('th', { scope: 'col' }, 'Effect added'),
        h('th', { scope: 'col', class: 'num' }, 'Gap RMS before → after (µm)'),
        h('th', { scope: 'col' }, 'Evidence'),
        h('th', { scope: 'col', class: 'num', title: 'F-test of the fit with the effect against the fit without it' }, 'p-value'),
        h('th', { scope: 'col', class: 'num', title: 'Change of the prediction error on held-out tests (cross-validated PRESS)' }, 'Held-out prediction error'),
      ),
    ),
    body,
  );
}

function candidateOutcome(c, chosen) {
  if (chosen) return 'added';
  if (c.qualified) return 'qualified, not the best';
  return c.rejected_because ? `rejected: ${c.rejected_because}` : 'rejected';
}

// Every candidate tried at every step (hexapod study), and those left at the stop.
function candidatesBox(r) {
  const steps = Array.isArray(r.steps) ? r.steps : [];
  const rows = [];
  steps.forEach((s, i) => {
    const ev = s.evidence || {};
    for (const c of Array.isArray(ev.candidates) ? ev.candidates : []) {
      const chosen = c.effect === s.added_effect && (c.variant || '') === (ev.variant || '');
      rows.push({ step: String(i + 1), c, chosen });
    }
  });
  for (const c of Array.isArray(r.candidates_at_stop) ? r.candidates_at_stop : []) rows.push({ step: 'stop', c, chosen: false });
  if (!rows.length) return null;
  return h(
    'details',
    { class: 'disc-more', 'data-testid': 'disc-candidates' },
    h('summary', {}, `Candidates tried (${rows.length})`),
    h(
      'div',
      { class: 'table-scroll' },
      h(
        'table',
        { class: 'figures small' },
        h(
          'thead',
          {},
          h(
            'tr',
            {},
            h('th', { scope: 'col', class: 'num' }, 'Step'),
            h('th', { scope: 'col' }, 'Candidate'),
            h('th', { scope: 'col', class: 'num' }, 'p-value'),
            h('th', { scope: 'col', class: 'num' }, 'Held-out PRESS (µm²)'),
            h('th', { scope: 'col' }, 'Outcome'),
          ),
        ),
        h(
          'tbody',
          {},
          ...rows.map(({ step, c, chosen }) =>
            h(
              'tr',
              { class: chosen ? 'chosen' : c.qualified ? '' : 'rejected', 'data-step': step, 'data-effect': c.effect },
              h('td', { class: 'num' }, step),
              h('th', { scope: 'row' }, effectLabel(c.effect, c.variant)),
              h('td', { class: 'num' }, ...pValueNodes(c.p_value, c.log10_p_value)),
              h('td', { class: 'num' }, plain(c.cv_press_um2)),
              h('td', {}, candidateOutcome(c, chosen)),
            ),
          ),
        ),
      ),
    ),
  );
}

function gapChartBox(r) {
  const steps = Array.isArray(r.steps) ? r.steps : [];
  const bars = [
    { step: 0, effect: '', label: r.kind === 'hexapod' ? 'Base model (kinematic parameters)' : 'Base model', gap: baseGap(r) },
    ...steps.map((s, i) => ({ step: i + 1, effect: s.added_effect, label: `Step ${i + 1}: + ${effectWords(s.added_effect)}`, gap: s.gap_rms_after_um })),
  ].filter((b) => typeof b.gap === 'number' && Number.isFinite(b.gap));
  const fig = h('figure', { class: 'chart-box gap-chart-box' });
  const narrow = window.matchMedia ? window.matchMedia('(max-width: 640px)').matches : false;
  fig.append(renderGapChart(bars, r.noise_floor_um, { narrow }));
  fig.append(h('figcaption', {}, 'RMS of the difference between the tests and the model, after each step; the dashed line is the noise floor of the tests (below it nothing more can be explained).'));
  return fig;
}

// Gap RMS of every test: base model, then after each step (hexapod results carry them).
function testGapsBox(r) {
  const steps = Array.isArray(r.steps) ? r.steps : [];
  const base = Array.isArray(r.base?.tests) ? r.base.tests : [];
  if (!base.length) return null;
  const key = (t) => `${t.file ?? ''}|${t.test_id ?? ''}|${t.direction ?? ''}`;
  const after = steps.map((s) => {
    const m = new Map();
    (Array.isArray(s.tests) ? s.tests : []).forEach((t, i) => {
      m.set(key(t), t.gap_rms_after_um);
      m.set(`#${i}`, t.gap_rms_after_um);
    });
    return m;
  });
  const fileText = (f) => {
    const m = String(f || '').match(/^measurement (\d+)$/);
    return m ? `#${m[1]}` : String(f || '').split('/').pop();
  };
  return h(
    'details',
    { class: 'disc-more', 'data-testid': 'disc-test-gaps' },
    h('summary', {}, `Gap of each test at each step (${plural(base.length, 'test')})`),
    h(
      'div',
      { class: 'table-scroll' },
      h(
        'table',
        { class: 'figures small disc-test-table' },
        h('caption', {}, 'Gap RMS per test (µm): base model, then after each step'),
        h(
          'thead',
          {},
          h(
            'tr',
            {},
            h('th', { scope: 'col' }, 'Test'),
            h('th', { scope: 'col' }, 'Direction'),
            h('th', { scope: 'col' }, 'Measurement'),
            h('th', { scope: 'col', class: 'num' }, 'Base'),
            ...steps.map((s, i) => h('th', { scope: 'col', class: 'num', 'data-step': i + 1 }, `+ ${effectWords(s.added_effect)}`)),
          ),
        ),
        h(
          'tbody',
          {},
          ...base.map((t, i) =>
            h(
              'tr',
              { 'data-test-id': t.test_id, 'data-direction': t.direction },
              h('th', { scope: 'row' }, t.test_id ?? '—'),
              h('td', {}, formatDirection(t.direction)),
              h('td', { class: 'col-id' }, fileText(t.file)),
              h('td', { class: 'num', 'data-step': 0 }, um(t.gap_rms_before_um)),
              ...after.map((m, k) => {
                const v = m.has(key(t)) ? m.get(key(t)) : m.get(`#${i}`);
                return h('td', { class: 'num', 'data-step': k + 1 }, um(v));
              }),
            ),
          ),
        ),
      ),
    ),
  );
}

function kinematicTable(entry) {
  const p = entry.parameters || {};
  const u = entry.uncertainty || {};
  const fixed = new Set(Array.isArray(entry.fixed_parameters) ? entry.fixed_parameters : []);
  const cell = (name, v, s) =>
    h(
      'td',
      { class: `num${fixed.has(name) ? ' fixed' : ''}`, 'data-param': name, title: fixed.has(name) ? 'fixed (not identifiable from these tests)' : null },
      fixed.has(name) ? `${um(v)} (fixed)` : `${um(v)} ± ${um(s)}`,
    );
  return h(
    'table',
    { class: 'figures small disc-kinematic', 'data-testid': 'disc-kinematic' },
    h('caption', {}, 'Kinematic parameters: strut length offsets and base-joint position errors (µm, ± standard uncertainty)'),
    h(
      'thead',
      {},
      h(
        'tr',
        {},
        h('th', { scope: 'col' }, 'Strut'),
        h('th', { scope: 'col', class: 'num' }, 'Length offset'),
        h('th', { scope: 'col', class: 'num' }, 'Base joint X'),
        h('th', { scope: 'col', class: 'num' }, 'Base joint Y'),
        h('th', { scope: 'col', class: 'num' }, 'Base joint Z'),
      ),
    ),
    h(
      'tbody',
      {},
      ...[0, 1, 2, 3, 4, 5].map((j) =>
        h(
          'tr',
          { 'data-strut': j },
          h('th', { scope: 'row' }, String(j + 1)),
          cell(`strut_offset_um[${j}]`, p.strut_offset_um?.[j], u.strut_offset_um?.[j]),
          ...[0, 1, 2].map((c) => cell(`base_joint_offset_um[${j}][${c}]`, p.base_joint_offset_um?.[j]?.[c], u.base_joint_offset_um?.[j]?.[c])),
        ),
      ),
    ),
  );
}

// Hexapod effects: one row per parameter, in words and human units.
function effectsTable(entries) {
  const rows = [];
  for (const e of entries) {
    const params = Object.entries(e.parameters || {});
    const fixed = new Set(Array.isArray(e.fixed_parameters) ? e.fixed_parameters : []);
    const atBound = new Set(Array.isArray(e.at_bound) ? e.at_bound : []);
    params.forEach(([name, value], i) => {
      const w = parameterWords(name);
      const sigma = e.uncertainty?.[name];
      const isFixed = fixed.has(name);
      const shown = typeof value === 'number' ? value * w.factor : value;
      rows.push(
        h(
          'tr',
          { 'data-effect': e.effect, 'data-param': name, class: isFixed ? 'fixed-row' : '' },
          i === 0 ? h('th', { scope: 'rowgroup', rowspan: params.length, class: 'effect-cell' }, effectWords(e.effect)) : null,
          h('td', { class: 'param-name' }, w.label),
          h(
            'td',
            { class: `num${isFixed ? ' fixed' : ''}`, 'data-key': 'value' },
            isFixed
              ? `${plain(shown)} (held at the machine file's value)`
              : atBound.has(name)
                ? `${plain(shown)} (on its bound: held there, not estimated)`
                : valuePm(shown, typeof sigma === 'number' ? sigma * w.factor : null),
          ),
          h('td', { class: 'unit' }, w.unit),
        ),
      );
    });
  }
  return h(
    'table',
    { class: 'figures small disc-effects stack-narrow', 'data-testid': 'disc-effects' },
    h('caption', {}, 'Effects found (± standard uncertainty)'),
    h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Effect'), h('th', { scope: 'col' }, 'Parameter'), h('th', { scope: 'col', class: 'num' }, 'Value'), h('th', { scope: 'col', class: 'unit' }, 'Unit'))),
    h('tbody', {}, ...rows),
  );
}

// Serial final model: {effect, value (number or [x, y]), unit, sigma}.
function serialModelTable(entries) {
  const text = (e) => {
    if (Array.isArray(e.value)) {
      const axes = ['X', 'Y', 'Z'];
      return e.value.map((v, i) => `${axes[i] || i + 1} ${valuePm(v, Array.isArray(e.sigma) ? e.sigma[i] : e.sigma)}`).join(', ');
    }
    return valuePm(e.value, e.sigma);
  };
  return h(
    'table',
    { class: 'figures small disc-effects', 'data-testid': 'disc-effects' },
    h('caption', {}, 'Effects found (± standard uncertainty)'),
    h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Effect'), h('th', { scope: 'col', class: 'num' }, 'Value'), h('th', { scope: 'col', class: 'unit' }, 'Unit'))),
    h(
      'tbody',
      {},
      ...entries.map((e) =>
        h('tr', { 'data-effect': e.effect }, h('th', { scope: 'row' }, effectWords(e.effect)), h('td', { class: 'num', 'data-key': 'value' }, text(e)), h('td', { class: 'unit' }, displayUnit(e.unit))),
      ),
    ),
  );
}

function finalModelBox(r) {
  const model = Array.isArray(r.final_model) ? r.final_model : [];
  const box = h('section', { class: 'disc-block', 'data-testid': 'disc-final-model', 'aria-labelledby': 'disc-final-heading' }, h('h3', { id: 'disc-final-heading' }, 'Final model'));
  if (r.kind === 'hexapod') {
    const kin = model.find((e) => e.effect === 'kinematic_parameters');
    const effects = model.filter((e) => e.effect !== 'kinematic_parameters');
    if (effects.length) box.append(h('div', { class: 'table-scroll' }, effectsTable(effects)));
    else box.append(h('p', { class: 'note' }, 'No effect beyond the kinematic parameters.'));
    if (kin) box.append(h('div', { class: 'table-scroll' }, kinematicTable(kin)));
  } else if (model.length) {
    box.append(h('div', { class: 'table-scroll' }, serialModelTable(model)));
  } else {
    box.append(h('p', { class: 'note' }, 'No effect was identified.'));
  }
  const extra = [];
  if (Array.isArray(r.not_identifiable) && r.not_identifiable.length) extra.push(`Not identifiable from these tests: ${r.not_identifiable.map((x) => effectWords(x)).join(', ')}.`);
  if (Array.isArray(r.rejected) && r.rejected.length) extra.push(`Rejected: ${r.rejected.map(sentenceWords).join('; ')}.`);
  for (const t of extra) box.append(h('p', { class: 'note muted-note' }, t));
  return box;
}

function compensationBox(r) {
  const c = r.compensation;
  if (!c || !Array.isArray(c.tests) || !c.tests.length) return null;
  const effects = (c.compensated_effects || []).map((e) => effectWords(e).toLowerCase());
  return h(
    'section',
    { class: 'disc-block', 'data-testid': 'disc-compensation', 'aria-labelledby': 'disc-comp-heading' },
    h('h3', { id: 'disc-comp-heading' }, 'Compensation preview'),
    h('p', { class: 'note' }, `Circularity of each test as measured, and as predicted with the command corrected for ${effects.join(' and ') || 'the effects found'} (as [PM-600 report] table 4.5).`),
    h(
      'div',
      { class: 'table-scroll' },
      h(
        'table',
        { class: 'figures small disc-comp' },
        h(
          'thead',
          {},
          h(
            'tr',
            {},
            h('th', { scope: 'col' }, 'Test'),
            h('th', { scope: 'col' }, 'Direction'),
            h('th', { scope: 'col', class: 'num' }, 'Circularity without compensation (µm)'),
            h('th', { scope: 'col', class: 'num' }, 'Predicted with compensation (µm)'),
            h('th', { scope: 'col', class: 'num' }, 'Change'),
          ),
        ),
        h(
          'tbody',
          {},
          ...c.tests.map((t) => {
            const a = t.circularity_without_compensation_um;
            const b = t.predicted_circularity_with_compensation_um;
            const change = typeof a === 'number' && typeof b === 'number' && a > 0 ? (100 * (b - a)) / a : null;
            return h(
              'tr',
              { 'data-test-id': t.test_id, 'data-direction': t.direction },
              h('th', { scope: 'row' }, t.test_id ?? '—'),
              h('td', {}, formatDirection(t.direction)),
              h('td', { class: 'num', 'data-key': 'circularity_without_compensation_um' }, um(a)),
              h('td', { class: 'num', 'data-key': 'predicted_circularity_with_compensation_um' }, um(b)),
              h('td', { class: 'num', 'data-key': 'change' }, change === null ? '—' : `${change > 0 ? '+' : change < 0 ? '−' : ''}${pct(Math.abs(change))}`),
            );
          }),
        ),
      ),
    ),
  );
}

// Save the updated machine as a new model version; download the result JSON.
function actionsBox(job, r) {
  const box = h('div', { class: 'disc-actions', 'data-testid': 'disc-actions' });
  const status = h('div', { class: 'message', 'data-testid': 'disc-save-status', 'aria-live': 'polite', hidden: true });
  if (r && r.updated_machine) {
    const button = h(
      'button',
      {
        type: 'button',
        'data-testid': 'disc-save',
        'data-min-role': 'engineer',
        onclick: async () => {
          button.disabled = true;
          setMessage(status, 'info', 'Saving…');
          try {
            const out = await api.saveJobMachine(job.id);
            status.dataset.version = out.version;
            status.dataset.machineId = out.machine_id;
            setMessage(
              status,
              'success',
              h('strong', { class: 'problem-title' }, out.created ? `Saved as ${out.machine_id} version ${out.version}` : `Already stored as ${out.machine_id} version ${out.version}`),
              h('span', {}, out.created ? 'New discoveries and calibrations can start from this version.' : 'The newest version holds the same machine: nothing new was stored.'),
            );
            await ctx.reloadMachines();
          } catch (err) {
            if (!ctx.handleAuth(err)) setMessage(status, 'error', ...problemContent(asProblem(err, 'Not saved')));
          } finally {
            button.disabled = false;
          }
        },
      },
      'Save as new machine model version',
    );
    box.append(button);
  } else if (r) {
    box.append(h('span', { class: 'note' }, r.kind === 'hexapod' ? 'This job produced no machine model to save.' : 'A serial study produces no machine model to save.'));
  }
  if (r) {
    if (result.jsonUrl) URL.revokeObjectURL(result.jsonUrl);
    result.jsonUrl = URL.createObjectURL(new Blob([`${JSON.stringify(r, null, 2)}\n`], { type: 'application/json' }));
    box.append(h('a', { class: 'button-link secondary-link', href: result.jsonUrl, download: `kinemetric-discovery-job-${job.id}.json`, 'data-testid': 'disc-download' }, 'Download result (JSON)'));
  }
  box.append(h('a', { class: 'button-link secondary-link', href: newFormHash(ctx.getMachineId()), 'data-testid': 'disc-new-again', 'data-min-role': 'engineer' }, 'New discovery'));
  return h('div', {}, box, status);
}

export function renderResult(job) {
  const r = job.result || {};
  const box = $('#disc-result');
  const parts = [
    verdictBanner(r),
    summaryList(job, r),
    h(
      'section',
      { class: 'disc-block', 'aria-labelledby': 'disc-steps-heading' },
      h('h3', { id: 'disc-steps-heading' }, 'How the gap shrank'),
      gapChartBox(r),
      h('div', { class: 'table-scroll' }, stepsTable(r)),
      candidatesBox(r),
      testGapsBox(r),
    ),
    finalModelBox(r),
    compensationBox(r),
    actionsBox(job, r),
  ];
  box.replaceChildren(...parts.filter(Boolean));
  box.dataset.jobId = job.id;
}
