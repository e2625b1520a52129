// Browser scenario of an audit that judges every set-up (docs/http.md, "Accuracy audits"): rules
// scoped to set-ups set in the page's rule editor (a test_id pattern with *, a DBB direction, a
// positioning axis — each offered only for its kind), the audit's max_age_days and what a stale
// set-up gives, stored as the API keeps them and shown again; then a run, and the verdict view
// naming the set-up and the measurement of every finding and every checked entry, and listing the
// stale set-ups with their date (UTC).
//   node tests/browser/dashboard/audit_setups.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { dbbFile, outDir, withDashboard } from '../lib/harness.mjs';

const MACHINE = 'setups-vmc';

const go = (page, hash) =>
  page.evaluate((h) => {
    window.location.hash = h;
  }, hash);

const utc = (iso) => `${new Date(iso).toISOString().slice(0, 16).replace('T', ' ')} UTC`;

// Set-ups measured in one session (xy-r150 CCW and CW, xy-r100 CW) and one measured long ago
// (yz-r150 CCW, stale beyond 200 days).
async function uploadSession(api) {
  const ids = {};
  ids.xyCcw = (await api.upload(dbbFile({ machine: MACHINE, test: 'xy-r150', direction: 'ccw', timestamp: '2026-11-30T08:00:00Z', shape: 0 }), 'xy150_ccw.txt')).id;
  ids.xyCw = (await api.upload(dbbFile({ machine: MACHINE, test: 'xy-r150', direction: 'cw', timestamp: '2026-11-30T08:05:00Z', shape: 3 }), 'xy150_cw.txt')).id;
  ids.xy100 = (await api.upload(dbbFile({ machine: MACHINE, test: 'xy-r100', direction: 'cw', timestamp: '2026-11-30T08:10:00Z', shape: 1 }), 'xy100_cw.txt')).id;
  ids.yzOld = (await api.upload(dbbFile({ machine: MACHINE, test: 'yz-r150', direction: 'ccw', timestamp: '2025-01-15T08:00:00Z', shape: 2, extra: ['# plane: YZ'] }), 'yz150_ccw.txt')).id;
  return ids;
}

async function fillRule(page, i, rule) {
  const row = page.locator('[data-testid="audit-rule-edit"]').nth(i);
  await row.locator('[data-key="kind"]').selectOption(rule.kind);
  await row.locator('[data-key="metric"]').fill(rule.metric);
  await row.locator('[data-key="warn"]').fill(rule.warn === undefined ? '' : String(rule.warn));
  await row.locator('[data-key="stop"]').fill(rule.stop === undefined ? '' : String(rule.stop));
  await row.locator('[data-key="test_id"]').fill(rule.test_id || '');
  if (rule.kind === 'dbb') await row.locator('[data-key="direction"]').selectOption(rule.direction || '');
  if (rule.kind === 'positioning') await row.locator('[data-key="axis"]').fill(rule.axis || '');
}

test('rules scoped to set-ups, stale set-ups, every set-up judged and named', { timeout: 170_000 }, async () => {
  await withDashboard('audit-setups', async ({ server, api, page, open }) => {
    const ids = await uploadSession(api);
    const circ = {};
    for (const [k, id] of Object.entries(ids)) circ[k] = (await api.get(`/api/v1/measurements/${id}/results`)).circularity_um;
    const lo = Math.min(circ.xyCcw, circ.xyCw, circ.xy100);
    const hi = Math.max(circ.xyCcw, circ.xyCw, circ.xy100);
    assert.ok(hi - lo > 0.1, `the set-ups differ: ${JSON.stringify(circ)}`);

    await open(`#/machines/${MACHINE}/audit`);
    await page.waitForSelector(`#audit-view:not([hidden])[data-machine-id="${MACHINE}"] [data-testid="audit-no-rules"]`);
    // The scope fields follow the kind: a direction for DBB, an axis for positioning.
    const first = page.locator('[data-testid="audit-rule-edit"]').first();
    assert.equal(await first.locator('[data-key="direction"]').isVisible(), true);
    assert.equal(await first.locator('[data-key="axis"]').isVisible(), false);
    await first.locator('[data-key="kind"]').selectOption('positioning');
    assert.equal(await first.locator('[data-key="direction"]').isVisible(), false);
    assert.equal(await first.locator('[data-key="axis"]').isVisible(), true);

    // Rule 1: every xy-* set-up, warn between the set-ups, stop below the worst. Rule 2: the CW
    // test of xy-r150 only. Rule 3: axis X of the positioning tests (none stored). Rule 4: every
    // DBB set-up, the stale one too.
    const warn = Number(((lo + hi) / 2).toFixed(2));
    const rules = [
      { kind: 'dbb', metric: 'circularity_um', warn, stop: Number((hi - 0.05).toFixed(2)), test_id: 'xy-*' },
      { kind: 'dbb', metric: 'circularity_um', warn: 1000, test_id: 'xy-r150', direction: 'cw' },
      { kind: 'positioning', metric: 'accuracy_um', warn: 10, stop: 20, axis: 'X' },
      { kind: 'dbb', metric: 'centre_offset_um', warn: 5000 },
    ];
    await fillRule(page, 0, rules[0]);
    for (let i = 1; i < rules.length; ++i) {
      await page.click('[data-testid="audit-add-rule"]');
      await fillRule(page, i, { ...rules[i], axis: rules[i].axis ? rules[i].axis.toLowerCase() : undefined });
    }
    await page.fill('[data-testid="audit-max-age"]', '200');
    await page.selectOption('[data-testid="audit-stale"]', 'warn');
    let body = null;
    page.on('request', (req) => {
      if (req.method() === 'PUT' && req.url().endsWith(`/machines/${MACHINE}/audit`)) body = JSON.parse(req.postData());
    });
    await page.click('[data-testid="audit-save"]');
    await page.waitForSelector('[data-testid="audit-form-status"].success, [data-testid="audit-form-status"].error');
    assert.deepEqual(body, { schedule: null, rules, max_age_days: 200, stale: 'warn' }, 'the page sends the keys of the API');
    const status = await page.textContent('[data-testid="audit-form-status"]');
    assert.match(status, /Saved 4 rules/, `the server keeps scoped rules, max_age_days and stale: ${status}`);
    const stored = await api.get(`/api/v1/machines/${MACHINE}/audit`);
    assert.equal(stored.max_age_days, 200);
    assert.equal(stored.stale, 'warn');
    assert.deepEqual(stored.rules.map((r) => [r.test_id, r.direction, r.axis]), [['xy-*', undefined, undefined], ['xy-r150', 'cw', undefined], [undefined, undefined, 'X'], [undefined, undefined, undefined]]);
    // Shown again in the form and the rules table.
    await page.reload();
    await page.waitForSelector('body[data-ready="true"]');
    await go(page, `#/machines/${MACHINE}/audit`);
    await page.waitForSelector(`#audit-view:not([hidden])[data-machine-id="${MACHINE}"] [data-testid="audit-rules"]`);
    assert.equal(await page.inputValue('[data-testid="audit-max-age"]'), '200');
    assert.equal(await page.inputValue('[data-testid="audit-stale"]'), 'warn');
    const second = page.locator('[data-testid="audit-rule-edit"]').nth(1);
    assert.equal(await second.locator('[data-key="test_id"]').inputValue(), 'xy-r150');
    assert.equal(await second.locator('[data-key="direction"]').inputValue(), 'cw');
    assert.equal(await page.locator('[data-testid="audit-rule-edit"]').nth(2).locator('[data-key="axis"]').inputValue(), 'X');
    const scopes = await page.$$eval('[data-testid="audit-rules"] [data-testid="audit-rule-scope"]', (ss) => ss.map((s) => s.textContent));
    assert.deepEqual(scopes, [' — tests xy-*', ' — test xy-r150, CW', ' — axis X']);

    // Run: the verdict names the set-up and measurement of everything it judged.
    await page.click('[data-testid="audit-run"]');
    await page.waitForSelector('[data-testid="audit-status"].warning, [data-testid="audit-status"].success');
    const verdict = (await api.get(`/api/v1/audits?machine_id=${MACHINE}`)).audits[0];
    await page.waitForSelector(`#audit-view [data-testid="audit-level"][data-audit-level="${verdict.level}"]`);
    assert.equal(verdict.level, 3, 'the worst xy set-up is above the stop limit');
    for (const x of [...verdict.findings, ...verdict.checked].filter((e) => e.measurement_id !== undefined)) {
      for (const key of ['set_up', 'test_id', 'direction']) assert.ok(key in x, `${key} in ${JSON.stringify(x)}`);
    }
    const judged = verdict.checked.filter((c) => c.rule === 0 && c.measurement_id !== undefined).map((c) => c.measurement_id).sort((a, b) => a - b);
    assert.deepEqual(judged, [ids.xyCcw, ids.xyCw, ids.xy100].sort((a, b) => a - b), 'rule 1 judges every xy set-up, not yz');
    assert.ok(verdict.checked.filter((c) => c.rule === 1).every((c) => c.test_id === 'xy-r150' && c.direction === 'cw'), 'rule 2 only where it says');
    // Findings: each with its set-up and its measurement.
    const findings = await page.$$eval('[data-testid="audit-finding"]', (ls) =>
      ls.map((l) => [l.dataset.setUp, Number(l.querySelector('[data-finding-measurement]')?.dataset.findingMeasurement) || null, l.textContent]),
    );
    assert.equal(findings.length, verdict.findings.length);
    verdict.findings.forEach((f, i) => {
      assert.equal(findings[i][0], f.set_up);
      assert.ok(findings[i][2].includes(`set-up ${f.set_up}`), findings[i][2]);
      if (f.measurement_id !== undefined && f.measurement_id !== null) assert.equal(findings[i][1], f.measurement_id);
    });
    // Every checked entry: one row with its set-up, status and measurement.
    const rows = await page.$$eval('[data-testid="audit-checked"] tbody tr', (trs) =>
      trs.map((tr) => [Number(tr.dataset.checkedRule), tr.dataset.setUp, tr.dataset.status, Number(tr.querySelector('[data-checked-measurement]')?.dataset.checkedMeasurement) || null]),
    );
    assert.deepEqual(rows, verdict.checked.map((c) => [c.rule, c.set_up ?? '', c.status, c.measurement_id ?? null]));
    // The stale set-up, with its date, and a level-2 finding for it (the audit asks for it).
    const stale = verdict.stale || [];
    assert.ok(stale.some((s) => s.measurement_id === ids.yzOld), `yz-r150 is stale: ${JSON.stringify(stale)}`);
    const staleShown = await page.$$eval('[data-testid="audit-stale-item"]', (ls) => ls.map((l) => [l.dataset.setUp, l.textContent]));
    assert.deepEqual(staleShown.map((s) => s[0]), stale.map((s) => s.set_up));
    stale.forEach((s, i) => assert.ok(staleShown[i][1].includes(utc(s.measured_at)), staleShown[i][1]));
    assert.ok(verdict.findings.some((f) => f.level === 2 && f.measurement_id === ids.yzOld), 'the stale set-up is a level-2 finding');
    await page.locator('#audit-view').screenshot({ path: join(outDir, 'audit-setups.png') });
  });
});
