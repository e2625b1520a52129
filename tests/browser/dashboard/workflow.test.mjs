// Browser scenarios of the operator's workflow around the measurement views:
// - the landing view (what the product does; uploading, machines and audits named; the newest
//   uploads), and an address naming nothing (an unknown machine, an unknown view) said in words;
// - a machine's accuracy audit (#/machines/ID/audit): rules set on the page through its form (a
//   wrong limit refused naming rules[0].warn, nothing stored), run, the level, one row a rule,
//   each finding linked to its measurement, and which of two tests of the same moment was
//   judged and why; the same level, rules and links beside the machine's list;
// - trends with one series a test and direction, by default the figure that set the level;
// - the straightness reversal of a pair (machine and artefact curves, data-reversal-partner);
// - the tokens page (list with last use, make, revoke) and what a viewer is not offered;
// - 400 px: the chosen measurement within the first screen, nothing wider than the window.
//   node tests/browser/dashboard/workflow.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { assertNoHorizontalOverflow, dbbFile, makeToken, outDir, repo, withDashboard } from '../lib/harness.mjs';

const MACHINE = 'workflow-vmc';


const go = (page, hash) =>
  page.evaluate((h) => {
    window.location.hash = h;
  }, hash);

// Four DBB tests: an older CCW/CW pair and a newer one, CW 5 min after CCW; shapes differ so the
// circularities differ.
async function uploadPairs(api) {
  const ids = {};
  ids.oldCcw = (await api.upload(dbbFile({ machine: MACHINE, direction: 'ccw', timestamp: '2026-03-01T08:00:00Z', shape: 0 }), 'old_ccw.txt')).id;
  ids.oldCw = (await api.upload(dbbFile({ machine: MACHINE, direction: 'cw', timestamp: '2026-03-01T08:05:00Z', shape: 0 }), 'old_cw.txt')).id;
  ids.ccw = (await api.upload(dbbFile({ machine: MACHINE, direction: 'ccw', timestamp: '2026-04-01T08:00:00Z', shape: 1 }), 'new_ccw.txt')).id;
  ids.cw = (await api.upload(dbbFile({ machine: MACHINE, direction: 'cw', timestamp: '2026-04-01T08:05:00Z', shape: 3 }), 'new_cw.txt')).id;
  return ids;
}

// Clicks a "PDF report" button; the saved file is a PDF whose text (pdftotext) is returned.
async function pdfText(page, selector) {
  const [download] = await Promise.all([page.waitForEvent('download'), page.click(selector)]);
  const path = await download.path();
  assert.equal(readFileSync(path).subarray(0, 5).toString(), '%PDF-');
  assert.match(download.suggestedFilename(), /^kinemetric-.*\.pdf$/);
  return execFileSync('pdftotext', ['-layout', path, '-']).toString();
}

async function setRule(page, i, { kind, metric, warn = '', stop = '' }) {
  const row = page.locator('[data-testid="audit-rule-edit"]').nth(i);
  await row.locator('[data-key="kind"]').selectOption(kind);
  await row.locator('[data-key="metric"]').fill(metric);
  await row.locator('[data-key="warn"]').fill(String(warn));
  await row.locator('[data-key="stop"]').fill(String(stop));
}

test('landing, unknown addresses, audit view and form, trends per test', { timeout: 110_000 }, async () => {
  await withDashboard('workflow-audit', async ({ server, api, page, open }) => {
    const ids = await uploadPairs(api);
    const circ = {};
    for (const [k, id] of Object.entries(ids)) circ[k] = (await api.get(`/api/v1/measurements/${id}/results`)).circularity_um;

    // Landing: the product in words, how to start, the newest uploads.
    await open();
    await page.waitForSelector('#home-view:not([hidden]) [data-testid="home-uploads"] a');
    const landing = await page.textContent('#home-view');
    for (const word of [/upload/i, /machine/i, /audit/i]) assert.match(landing, word);
    assert.match(await page.textContent('[data-testid="home-uploads"]'), new RegExp(`#${ids.cw}\\b`));
    assert.equal(new URL(page.url()).hash, '', 'the landing view has the bare address');

    // Addresses naming nothing are said, not silently replaced.
    await go(page, '#/machines/nonexistent');
    await page.waitForSelector('[data-testid="unknown-address"]:not([hidden])');
    assert.match(await page.textContent('[data-testid="unknown-address"]'), /nonexistent/);
    await go(page, '#/no/such/view');
    await page.waitForFunction(() => /no\/such\/view/.test(document.querySelector('[data-testid="unknown-address"]').textContent));

    // The audit view without rules; a wrong rule is refused on the page and nothing is stored.
    await go(page, `#/machines/${MACHINE}/audit`);
    await page.waitForSelector(`#audit-view:not([hidden])[data-machine-id="${MACHINE}"][data-audit-level="none"] [data-testid="audit-no-rules"]`);
    const warn = (circ.ccw + circ.cw) / 2; // between the two tests of the newer pair
    const lo = Math.min(circ.ccw, circ.cw);
    const hi = Math.max(circ.ccw, circ.cw);
    assert.ok(hi - lo > 0.05, `the newer pair's tests differ: ${lo} and ${hi}`);
    await setRule(page, 0, { kind: 'dbb', metric: 'circularity_um', warn: hi + 5, stop: hi + 1 });
    await page.click('[data-testid="audit-save"]');
    await page.waitForSelector('[data-testid="audit-form-status"].error');
    assert.match(await page.textContent('[data-testid="audit-form-status"]'), /rules\[0\]\.warn/);
    const none = await fetch(`${server.base}/api/v1/machines/${MACHINE}/audit`, { headers: { Authorization: `Bearer ${server.token}` } });
    assert.equal(none.status, 404, 'nothing stored');
    // Two rules: the circularity warns when the CW test (the newer) is above warn; the centre
    // offset has a limit far above any value.
    await setRule(page, 0, { kind: 'dbb', metric: 'circularity_um', warn, stop: hi * 3 });
    await page.click('[data-testid="audit-add-rule"]');
    await setRule(page, 1, { kind: 'dbb', metric: 'centre_offset_um', warn: 500 });
    await page.click('[data-testid="audit-save"]');
    await page.waitForSelector('[data-testid="audit-form-status"].success');
    const stored = await api.get(`/api/v1/machines/${MACHINE}/audit`);
    assert.deepEqual(stored.rules.map((r) => [r.metric, r.warn]), [['circularity_um', warn], ['centre_offset_um', 500]]);

    // Run it: level, rules, findings linked to the judged measurement, the pair explained.
    await page.click('[data-testid="audit-run"]');
    assert.ok(circ.cw > circ.ccw, `the newer CW test is the worse: ${circ.cw} > ${circ.ccw}`);
    const judgedLevel = '2'; // the CW test, the newest, is above warn
    await page.waitForSelector(`#audit-view [data-testid="audit-level"][data-audit-level="${judgedLevel}"]`);
    assert.equal(await page.locator('#audit-view [data-audit-rule]').count(), 2);
    const verdict = (await api.get(`/api/v1/audits?machine_id=${MACHINE}`)).audits[0];
    assert.equal(String(verdict.level), judgedLevel);
    const links = await page.$$eval('#audit-view [data-finding-measurement]', (as) => as.map((a) => Number(a.dataset.findingMeasurement)));
    assert.deepEqual(links, verdict.findings.map((f) => f.measurement_id));
    assert.deepEqual(links, [ids.cw], 'the finding is on the newest test, CW');
    const note = await page.textContent('[data-testid="audit-pair-note"]');
    assert.match(note, new RegExp(`CW test #${ids.cw}\\b`));
    assert.match(note, new RegExp(`CCW partner #${ids.ccw}\\b`));
    assert.match(note, /newest/);
    assert.match(await page.textContent('[data-testid="audit-history"]'), /level/);
    await page.locator('#audit-view').screenshot({ path: join(outDir, 'workflow-audit.png') });
    // The audit as a PDF: machine, every rule, the level.
    const auditPdf = await pdfText(page, '[data-testid="audit-report-pdf"]');
    assert.match(auditPdf, new RegExp(MACHINE));
    assert.match(auditPdf, /DBB circularity F/);
    assert.match(auditPdf, new RegExp(`level ${judgedLevel} — `));

    // Beside the machine's list: level, rules, finding links.
    await go(page, `#/machines/${MACHINE}`);
    await page.waitForSelector(`#machine-audit-summary [data-audit-level="${judgedLevel}"]`);
    assert.equal(await page.locator('#machine-audit-summary [data-audit-rule]').count(), 2);
    assert.equal(await page.locator('#machine-audit-summary [data-finding-measurement]').count(), verdict.findings.length);

    // The measurement's PDF: machine, date, circularity, the audit's verdict.
    await go(page, `#/measurements/${ids.cw}`);
    await page.waitForSelector(`#detail[data-view="dbb"][data-measurement-id="${ids.cw}"]`);
    const dbbPdf = await pdfText(page, '[data-testid="report-pdf"]');
    assert.match(dbbPdf, new RegExp(MACHINE));
    assert.match(dbbPdf, /2026-04-01T08:05:00Z/);
    assert.match(dbbPdf, new RegExp(circ.cw.toFixed(2).replace('.', '\\.')));
    assert.match(dbbPdf, new RegExp(`level ${judgedLevel} — `));

    // Trends: one series per test and direction; the default figure is the one that set the level.
    await go(page, `#/machines/${MACHINE}/trends`);
    await page.waitForSelector(`#trends-view:not([hidden])[data-machine-id="${MACHINE}"] [data-testid="trend-chart"]`);
    assert.equal(await page.getAttribute('#trends-view', 'data-metric'), 'circularity_um');
    const series = await page.$$eval('[data-testid="trend-series"]', (gs) => gs.map((g) => [g.dataset.series, Number(g.dataset.points)]));
    assert.deepEqual(series.sort(), [['xy-r150 CCW', 2], ['xy-r150 CW', 2]]);
    const cwPoints = await page.$$eval('[data-series="xy-r150 CW"] [data-testid="trend-point"]', (cs) => cs.map((c) => Number(c.dataset.measurementId)));
    assert.deepEqual(cwPoints, [ids.oldCw, ids.cw]);

    // A discovery starts from the newest test of each set-up, each shown with its date and file.
    await go(page, `#/discoveries?machine=${MACHINE}`);
    await page.waitForFunction(() => document.querySelectorAll('[data-testid="disc-choice"]').length === 4);
    const ticked = await page.$$eval('[data-testid="disc-choice"]', (bs) => bs.filter((b) => b.checked).map((b) => Number(b.dataset.id)).sort((a, b) => a - b));
    assert.deepEqual(ticked, [ids.ccw, ids.cw].sort((a, b) => a - b));
    assert.equal(await page.textContent('#disc-count'), '2 of 4 chosen');
    assert.match(await page.textContent('#disc-measurements'), /2026-0\d-01 \d\d:\d\d · new_cw\.txt/);
  });
});

test('reversal pair, tokens page, viewer, 400 px', { timeout: 110_000 }, async () => {
  await withDashboard('workflow-tokens', async ({ server, api, page, open }) => {
    // The straightness reversal of the example pair.
    const a = await api.upload(readFileSync(join(repo, 'data/examples/straightness_reversal_a.txt'), 'utf8'), 'straightness_reversal_a.txt');
    const b = await api.upload(readFileSync(join(repo, 'data/examples/straightness_reversal_b.txt'), 'utf8'), 'straightness_reversal_b.txt');
    const rev = await api.get(`/api/v1/measurements/${a.id}/reversal`);
    await open(`#/measurements/${a.id}`);
    await page.waitForSelector(`#detail[data-measurement-id="${a.id}"][data-reversal-partner="${b.id}"] [data-testid="reversal-plot"]`);
    assert.equal(Number(await page.getAttribute('[data-testid="reversal-machine"]', 'data-points')), rev.reversal.machine_um.length);
    assert.equal(Number(await page.getAttribute('[data-testid="reversal-artefact"]', 'data-points')), rev.reversal.artefact_um.length);
    assert.match(await page.textContent('[data-testid="reversal-note"]'), new RegExp(`#${b.id}\\b`));
    // Streams: those of the machine shown; another machine's only with "all machines".
    const own = (await api.post('/api/v1/streams', JSON.stringify({ machine_id: a.machine_id || 'vmc-3axis', name: 'own' }))).id;
    const other = (await api.post('/api/v1/streams', JSON.stringify({ machine_id: 'other-lathe', name: 'other' }))).id;
    await page.click('[data-testid="streams-refresh"]');
    await page.waitForSelector(`[data-testid="streams-table"] tr[data-stream="${own}"]`);
    assert.equal(await page.locator(`[data-testid="streams-table"] tr[data-stream="${other}"]`).count(), 0);
    await page.check('[data-testid="streams-all"]');
    await page.waitForSelector(`[data-testid="streams-table"] tr[data-stream="${other}"]`);
    await page.uncheck('[data-testid="streams-all"]');

    // A DBB test afterwards shows no reversal.
    const dbb = (await api.upload(dbbFile({ machine: MACHINE, direction: 'ccw', timestamp: '2026-04-01T08:00:00Z' }), 'ccw.txt')).id;
    await go(page, `#/measurements/${dbb}`);
    await page.waitForSelector(`#detail[data-view="dbb"][data-measurement-id="${dbb}"]`);
    assert.equal(await page.getAttribute('#detail', 'data-reversal-partner'), null);

    // Tokens: the bootstrap token listed with its last use; one made and revoked on the page.
    await go(page, '#/tokens');
    await page.waitForSelector('#tokens-view:not([hidden]) [data-testid="tokens-table"] tr[data-token-id]');
    const tokens = (await api.get('/api/v1/tokens')).items;
    const rows = await page.$$eval('[data-testid="tokens-table"] tr[data-token-id]', (trs) => trs.map((tr) => Number(tr.dataset.tokenId)));
    assert.deepEqual(rows, tokens.map((t) => t.id));
    assert.ok(tokens[0].last_used_at, 'the bootstrap token has a last use');
    assert.notEqual(await page.textContent(`tr[data-token-id="${tokens[0].id}"] [data-key="last_used"]`), 'not used yet');
    await page.fill('#token-create-name', 'cell-3 tablet');
    await page.selectOption('#token-create-role', 'viewer');
    await page.click('[data-testid="token-create"]');
    await page.waitForSelector('[data-testid="token-secret"]');
    const secret = await page.textContent('[data-testid="token-secret"]');
    assert.match(secret, /^[0-9a-f]{64}$/);
    const made = (await api.get('/api/v1/tokens')).items.find((t) => t.name === 'cell-3 tablet');
    assert.equal(made.role, 'viewer');
    await page.waitForSelector(`tr[data-token-id="${made.id}"][data-state="active"]`);
    page.once('dialog', (d) => d.accept());
    await page.click(`tr[data-token-id="${made.id}"] [data-testid="token-revoke"]`);
    await page.waitForSelector(`tr[data-token-id="${made.id}"][data-state="revoked"]`);
    assert.match(await page.textContent('[data-testid="audit-log"]'), /DELETE \/api\/v1\/tokens/);

    // A viewer: no tokens link, no audit form or run button, no discovery form.
    const viewer = await makeToken(server, 'viewer', 'viewer');
    await page.goto('about:blank');
    await page.goto(`${server.base}/#token=${encodeURIComponent(viewer)}`);
    await page.waitForSelector('body[data-ready="true"][data-role="viewer"]');
    assert.equal(await page.isVisible('[data-testid="tokens-link"]'), false);
    await go(page, `#/machines/${MACHINE}/audit`);
    await page.waitForSelector('#audit-view:not([hidden]) [data-testid="audit-no-rules"]');
    assert.equal(await page.isVisible('#audit-form'), false, 'no rule form for a viewer');
    assert.equal(await page.isVisible('[data-testid="audit-run"]'), false);
    await go(page, `#/discoveries?machine=${MACHINE}`);
    await page.waitForSelector('[data-testid="discovery-new-role"]:visible');
    assert.equal(await page.isVisible('[data-testid="disc-run"]'), false, 'no Run discovery for a viewer');
    assert.equal(await page.isVisible('[data-testid="disc-store"]'), false, 'no Store model for a viewer');

    // 400 px: the chosen measurement in the first screen, nothing wider than the window.
    await page.setViewportSize({ width: 400, height: 800 });
    await go(page, `#/measurements/${a.id}`);
    await page.waitForSelector(`#detail[data-measurement-id="${a.id}"] [data-testid="reversal-plot"]`);
    const box = await page.locator('#detail').boundingBox();
    assert.ok(box && box.y < 800, `the view starts within the first screen (y ${box && box.y})`);
    await assertNoHorizontalOverflow(page, '400 px, straightness with its reversal');
    await page.screenshot({ path: join(outDir, 'workflow-400px.png') });
  });
});
