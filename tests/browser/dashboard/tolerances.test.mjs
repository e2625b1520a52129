// Browser scenario: tolerances per machine and set-up against a real server. An engineer types
// the machine's tolerance table on its page (a decimal comma "0,5" read as 0.5, an unreadable
// number refused naming the field and nothing sent); each measurement of the list and the
// measurement's view show a pass / fail badge, and each figure its own; a new table changes the
// verdicts at once, as the API answers them. A viewer sees the table but no editor.
//   node tests/browser/dashboard/tolerances.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { dbbFile, makeToken, withDashboard } from '../lib/harness.mjs';

const MACHINE = 'tol-vmc';

async function badges(page) {
  return page.$$eval('#measurements [data-testid="measurement-item"]', (items) =>
    Object.fromEntries(items.map((a) => [a.dataset.testId, a.querySelector('[data-testid="measurement-conformance"]')?.dataset.conformance])),
  );
}

async function fillRow(page, i, { metric, tolerance, test_id: testId }) {
  const row = page.locator('[data-testid="tolerance-edit"]').nth(i);
  await row.locator('[data-key="kind"]').selectOption('dbb');
  await row.locator('[data-key="metric"]').fill(metric);
  await row.locator('[data-key="tolerance"]').fill(tolerance);
  await row.locator('[data-key="test_id"]').fill(testId || '');
}

async function saveAndWait(page, version) {
  await page.click('[data-testid="tolerances-save"]');
  await page.waitForSelector(`#machine-tolerances[data-version="${version}"] [data-testid="tolerances-status"].success`);
}

test('tolerances typed on the machine page judge every measurement, pass and fail', { timeout: 110_000 }, async () => {
  await withDashboard('tolerances', async ({ server, api, page, open }) => {
    const a = await api.upload(dbbFile({ machine: MACHINE, test: 'xy-r150', direction: 'ccw', timestamp: '2026-04-01T08:00:00Z' }), 'a.txt');
    const b = await api.upload(dbbFile({ machine: MACHINE, test: 'yz-r150', direction: 'ccw', timestamp: '2026-04-01T09:00:00Z', shape: 2 }), 'b.txt');
    assert.equal(a.conformance.verdict, 'no tolerance');
    const ga = (await api.get(`/api/v1/measurements/${a.id}/results`)).iso230_4.circular_deviation_um;
    const gb = (await api.get(`/api/v1/measurements/${b.id}/results`)).iso230_4.circular_deviation_um;
    assert.ok(gb > ga + 1, `the two set-ups differ (G ${ga} and ${gb})`);

    await open(`#/machines/${MACHINE}`);
    await page.waitForSelector('#measurements [data-testid="measurement-conformance"]');
    assert.deepEqual(await badges(page), { 'xy-r150': 'no tolerance', 'yz-r150': 'no tolerance' });
    await page.waitForSelector('[data-testid="tolerances-form"]');

    // One tolerance for every DBB test, between the two G: xy-r150 passes, yz-r150 fails. Typed
    // with a decimal comma.
    const mid = Math.round(((ga + gb) / 2) * 10) / 10;
    await page.click('[data-testid="tolerance-add"]');
    await fillRow(page, 0, { metric: 'circular_deviation_um', tolerance: String(mid).replace('.', ',') });
    // An unreadable number is refused naming the field; nothing is sent.
    await page.click('[data-testid="tolerance-add"]');
    await fillRow(page, 1, { metric: 'circularity_um', tolerance: '1.234,5' });
    let puts = 0;
    const count = (req) => {
      if (req.method() === 'PUT') puts += 1;
    };
    page.on('request', count);
    await page.click('[data-testid="tolerances-save"]');
    await page.waitForSelector('[data-testid="tolerances-status"].error');
    const refusal = await page.textContent('[data-testid="tolerances-status"]');
    assert.ok(refusal.includes('tolerances[1].tolerance'), refusal);
    assert.equal(puts, 0, 'nothing is sent');
    page.off('request', count);
    await page.locator('[data-testid="tolerance-remove"]').nth(1).click();
    await saveAndWait(page, 1);
    const table = await api.get(`/api/v1/machines/${MACHINE}/tolerances`);
    assert.equal(table.version, 1);
    assert.equal(table.tolerances[0].tolerance, mid, 'the decimal comma is read as a decimal point');
    await page.waitForFunction(() => document.querySelector('#measurements [data-conformance="pass"]'));
    assert.deepEqual(await badges(page), { 'xy-r150': 'pass', 'yz-r150': 'fail' });
    const listed = await api.get(`/api/v1/measurements?machine_id=${MACHINE}`);
    for (const m of listed.items) assert.equal(m.conformance.verdict, m.test_id === 'xy-r150' ? 'pass' : 'fail');

    // The measurement's view: the verdict and each figure with its badge.
    await page.click(`#measurements [data-testid="measurement-item"][data-id="${b.id}"]`);
    await page.waitForSelector(`#detail[data-measurement-id="${b.id}"] [data-testid="conformance-panel"][data-conformance="fail"]`);
    const figure = await page.$eval('[data-testid="conformance-figures"] tr[data-metric="circular_deviation_um"] [data-testid="conformance-figure"]', (e) => e.dataset.conformance);
    assert.equal(figure, 'fail');

    // A table scoped to yz-r150 with a wide tolerance: both verdicts change at once.
    await fillRow(page, 0, { metric: 'circular_deviation_um', tolerance: String(Math.ceil(gb + 5)), test_id: 'yz-*' });
    await saveAndWait(page, 2);
    await page.waitForSelector(`#detail[data-measurement-id="${b.id}"] [data-testid="conformance-panel"][data-conformance="pass"]`);
    await page.waitForFunction(() => document.querySelector('#measurements [data-conformance="no tolerance"]'));
    assert.deepEqual(await badges(page), { 'xy-r150': 'no tolerance', 'yz-r150': 'pass' });
    assert.equal((await api.get(`/api/v1/measurements/${b.id}`)).conformance.tolerance_version, 2);
  });
});

test('a viewer sees the tolerance table and the badges, not the editor', { timeout: 110_000 }, async () => {
  await withDashboard('tolerances-viewer', async ({ server, api, page }) => {
    await api.upload(dbbFile({ machine: MACHINE, direction: 'ccw', timestamp: '2026-04-01T08:00:00Z' }), 'a.txt');
    const put = await fetch(`${server.base}/api/v1/machines/${MACHINE}/tolerances`, {
      method: 'PUT',
      headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': 'application/json' },
      body: JSON.stringify({ tolerances: [{ kind: 'dbb', metric: 'circular_deviation_um', tolerance: 0.5 }] }),
    });
    assert.equal(put.status, 200);
    const viewer = await makeToken(server, 'reader', 'viewer');
    const refused = await fetch(`${server.base}/api/v1/machines/${MACHINE}/tolerances`, {
      method: 'PUT',
      headers: { Authorization: `Bearer ${viewer}`, 'Content-Type': 'application/json' },
      body: JSON.stringify({ tolerances: [] }),
    });
    assert.equal(refused.status, 403);
    await page.goto(`${server.base}/#token=${encodeURIComponent(viewer)}`);
    await page.waitForSelector('body[data-ready="true"]');
    await page.evaluate((m) => {
      window.location.hash = `#/machines/${m}`;
    }, MACHINE);
    await page.waitForSelector('#machine-tolerances[data-version="1"] [data-testid="tolerances-list"]');
    assert.equal(await page.$('[data-testid="tolerances-form"]'), null, 'no editor for a viewer');
    await page.waitForSelector('#measurements [data-testid="measurement-conformance"][data-conformance="fail"]');
  });
});

test('a guarded table: each figure with ± U, its budget, and a figure within U of its tolerance undecided', { timeout: 110_000 }, async () => {
  await withDashboard('tolerances-guarded', async ({ api, page, open }) => {
    const extra = ['# u_reading_um: 0.4', '# u_bar_length_um: 1.5'];
    const a = await api.upload(dbbFile({ machine: MACHINE, test: 'xy-r150', direction: 'ccw', timestamp: '2026-04-01T08:00:00Z', extra }), 'a.txt');
    const r = await api.get(`/api/v1/measurements/${a.id}/results`);
    const g = r.iso230_4.circular_deviation_um;
    const U = r.uncertainty.figures.circular_deviation_um.U_um;
    assert.ok(U > 0.05 && U < g, `G ${g} ± ${U}`);

    await open(`#/machines/${MACHINE}`);
    await page.waitForSelector('[data-testid="tolerances-form"]');
    await page.selectOption('[data-testid="tolerances-rule-select"]', 'guarded');
    await page.click('[data-testid="tolerance-add"]');
    await fillRow(page, 0, { metric: 'circular_deviation_um', tolerance: g.toFixed(3) });
    await saveAndWait(page, 1);
    const table = await api.get(`/api/v1/machines/${MACHINE}/tolerances`);
    assert.equal(table.decision_rule.rule, 'guarded');
    await page.waitForFunction(() => document.querySelector('#measurements [data-conformance="undecided"]'));

    await page.click(`#measurements [data-testid="measurement-item"][data-id="${a.id}"]`);
    await page.waitForSelector(`#detail[data-measurement-id="${a.id}"] [data-testid="conformance-panel"][data-conformance="undecided"]`);
    const rule = await page.textContent('[data-testid="decision-rule"]');
    assert.ok(rule.includes('guarded'), rule);
    const uCell = await page.textContent('[data-testid="conformance-figures"] tr[data-metric="circular_deviation_um"] [data-testid="conformance-u"]');
    assert.ok(uCell.includes('±'), uCell);
    // ± U beside the figure in the figures table, and the budget on request.
    const beside = await page.textContent('[data-testid="figures-table"] tr[data-key="circularity_um"] [data-testid="figure-u"]');
    assert.match(beside, /±\s*\d/);
    await page.click('[data-testid="uncertainty-budget"] summary');
    const budget = await page.textContent('[data-testid="uncertainty-budget"]');
    assert.ok(budget.includes('u_reading_um') && budget.includes('u_bar_length_um') && budget.includes('Monte Carlo'), budget);
  });
});
