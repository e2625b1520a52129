// Browser scenario: the fleet overview, a machine's trend and what each role is shown.
// - #/fleet lists every machine with its newest measurement, number of measurements, open jobs
//   and audit level ("no audit" without one), exactly as GET /api/v1/fleet answers.
// - #/machines/{id}/trends?metric=circularity_um draws one point per DBB test with the stored
//   circularity, oldest first; the warn and stop lines of the machine's audit rules when the
//   rules are stored (PUT …/audit), none otherwise.
// - A viewer token: no upload panel; forced to show and used, the server's 403 is told as
//   "Your role (viewer) may not upload measurements." An operator token uploads.
//   node tests/browser/dashboard/fleet.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { assertNoHorizontalOverflow, dbbFile, makeToken, outDir, withDashboard } from '../lib/harness.mjs';

const MACHINE = 'trend-vmc';
const OTHER = 'fleet-lathe';


async function openAs(page, server, secret, role) {
  await page.goto('about:blank');
  await page.goto(`${server.base}/#token=${encodeURIComponent(secret)}`);
  await page.waitForSelector(`body[data-ready="true"][data-role="${role}"]`);
}

test('fleet overview, trends with limits, viewer and operator controls', { timeout: 110_000 }, async () => {
  await withDashboard('fleet', async ({ server, api, page, open }) => {
    const ids = [];
    for (const [k, day] of ['01', '08', '15'].entries()) {
      ids.push((await api.upload(dbbFile({ machine: MACHINE, direction: 'ccw', timestamp: `2026-03-${day}T08:00:00Z`, shape: k }), `t${k}.txt`)).id);
    }
    const lathe = (await api.upload(dbbFile({ machine: OTHER, direction: 'cw', timestamp: '2026-04-02T10:00:00Z' }), 'lathe.txt')).id;
    const circ = [];
    for (const id of ids) circ.push((await api.get(`/api/v1/measurements/${id}/results`)).circularity_um);

    // The fleet: the server's answer, then the page.
    const fleet = await api.get('/api/v1/fleet');
    const byId = Object.fromEntries(fleet.machines.map((m) => [m.machine_id, m]));
    assert.equal(byId[MACHINE].measurements, 3);
    assert.equal(byId[MACHINE].last_measurement.id, ids[2], 'the newest by measurement time');
    assert.equal(byId[MACHINE].last_measurement.kind, 'dbb');
    assert.equal(byId[MACHINE].last_measurement.measured_at, '2026-03-15T08:00:00Z');
    assert.equal(byId[OTHER].last_measurement.id, lathe);
    assert.equal(byId[MACHINE].open_jobs, 0);
    await open('#/fleet');
    await page.waitForSelector(`#fleet-view:not([hidden]) [data-testid="fleet-machine"][data-machine-id="${MACHINE}"]`);
    const rows = await page.$$eval('[data-testid="fleet-machine"]', (trs) =>
      trs.map((tr) => ({
        id: tr.dataset.machineId,
        audit: tr.querySelector('[data-testid="fleet-audit"]').textContent,
        level: tr.querySelector('[data-testid="fleet-audit"]').dataset.level,
        last: tr.querySelector('[data-testid="fleet-last"]').getAttribute('href'),
        n: Number(tr.querySelector('[data-key="measurements"]').textContent),
        jobs: Number(tr.querySelector('[data-key="open_jobs"]').textContent),
      })),
    );
    assert.deepEqual(rows.map((r) => r.id), fleet.machines.map((m) => m.machine_id));
    for (const r of rows) {
      const m = byId[r.id];
      assert.equal(r.last, `#/measurements/${m.last_measurement.id}`);
      assert.equal(r.n, m.measurements);
      assert.equal(r.jobs, m.open_jobs);
      if (m.audit) assert.match(r.audit, new RegExp(`^level ${m.audit.level} — `));
      else assert.deepEqual([r.audit, r.level], ['no audit', 'none']);
    }
    await page.locator('#fleet-view').screenshot({ path: join(outDir, 'fleet-overview.png') });
    await page.setViewportSize({ width: 400, height: 800 });
    await assertNoHorizontalOverflow(page, '400 px, fleet');
    await page.setViewportSize({ width: 1280, height: 900 });

    // Audit rules for the circularity (when the server keeps them): warn and stop lines.
    const rules = { schedule: null, rules: [{ kind: 'dbb', metric: 'circularity_um', warn: Math.max(...circ) * 0.9, stop: Math.max(...circ) * 1.2 }] };
    const put = await fetch(`${server.base}/api/v1/machines/${MACHINE}/audit`, {
      method: 'PUT',
      headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': 'application/json' },
      body: JSON.stringify(rules),
    });
    const withRules = put.ok;
    if (!withRules) console.log(`audit rules not stored (${put.status}): the trend is drawn without limits`);
    // An audit run: its findings on the circularity are marked on the trend's points.
    let findings = [];
    if (withRules) {
      const run = await fetch(`${server.base}/api/v1/machines/${MACHINE}/audit/run`, { method: 'POST', headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': 'application/json' }, body: '{}' });
      if (run.ok) findings = ((await run.json()).findings || []).filter((f) => f.metric === 'circularity_um' && f.measurement_id);
      else console.log(`audit run refused (${run.status}): no verdicts marked`);
      console.log(`audit findings on the circularity: ${JSON.stringify(findings)}`);
    }

    // The trend: one point per DBB test, the stored circularity, oldest first.
    await page.evaluate((m) => {
      window.location.hash = `#/machines/${m}/trends?metric=circularity_um`;
    }, MACHINE);
    await page.waitForSelector(`#trends-view:not([hidden])[data-machine-id="${MACHINE}"][data-metric="circularity_um"] [data-testid="trend-chart"]`);
    const trend = await api.get(`/api/v1/machines/${MACHINE}/trends?metric=circularity_um`);
    assert.deepEqual(trend.points.map((p) => [p.measurement_id, p.value]), ids.map((id, k) => [id, circ[k]]));
    const drawn = await page.$$eval('[data-testid="trend-point"]', (cs) => cs.map((c) => [Number(c.dataset.measurementId), Number(c.dataset.value), Number(c.getAttribute('cx'))]));
    assert.deepEqual(drawn.map(([id, v]) => [id, v]), ids.map((id, k) => [id, circ[k]]));
    assert.ok(drawn[0][2] < drawn[1][2] && drawn[1][2] < drawn[2][2], 'oldest on the left');
    const marked = await page.$$eval('[data-testid="trend-point"]', (cs) => cs.filter((c) => c.dataset.level).map((c) => [Number(c.dataset.measurementId), Number(c.dataset.level)]));
    const want = new Map();
    for (const f of findings) want.set(f.measurement_id, Math.max(want.get(f.measurement_id) || 0, f.level));
    assert.deepEqual(marked, [...want].sort((a, b) => a[0] - b[0]), 'audit verdicts marked on their points');
    if (withRules) {
      assert.equal(await page.getAttribute('#trends-view', 'data-limits'), 'rules');
      assert.equal(Number(await page.getAttribute('[data-testid="trend-limit-warn"]', 'data-value')), rules.rules[0].warn);
      assert.equal(Number(await page.getAttribute('[data-testid="trend-limit-stop"]', 'data-value')), rules.rules[0].stop);
    } else {
      assert.equal(await page.getAttribute('#trends-view', 'data-limits'), 'none');
      assert.equal(await page.locator('[data-testid^="trend-limit-"]').count(), 0);
    }
    await page.locator('#trends-view').screenshot({ path: join(outDir, 'fleet-trend.png') });
    await page.setViewportSize({ width: 400, height: 800 });
    await assertNoHorizontalOverflow(page, '400 px, trend');
    await page.setViewportSize({ width: 1280, height: 900 });
    // An unknown metric is refused naming the field.
    const bad = await fetch(`${server.base}/api/v1/machines/${MACHINE}/trends?metric=nonsense`, { headers: { Authorization: `Bearer ${server.token}` } });
    assert.equal(bad.status, 400);
    assert.equal((await bad.json()).field, 'metric');

    // After the audit run, the fleet shows its level in colour and words.
    if (findings.length) {
      const level = (await api.get('/api/v1/fleet')).machines.find((m) => m.machine_id === MACHINE).audit.level;
      assert.equal(level, Math.max(...findings.map((f) => f.level)));
      await page.evaluate(() => {
        window.location.hash = '#/fleet';
      });
      const cell = `[data-testid="fleet-machine"][data-machine-id="${MACHINE}"] [data-testid="fleet-audit"]`;
      await page.waitForSelector(`#fleet-view:not([hidden]) ${cell}[data-level="${level}"]`);
      assert.match(await page.textContent(cell), new RegExp(`^level ${level} — (warn|stop) \\(`));
      assert.match(await page.getAttribute(cell, 'class'), new RegExp(`level-${level}`));
    }

    // A viewer: the upload panel is not shown; forced to show, the 403 is told in words.
    const viewer = await makeToken(server, 'shop-floor screen', 'viewer');
    await openAs(page, server, viewer, 'viewer');
    assert.equal(await page.isHidden('#upload-panel'), true, 'no upload control for a viewer');
    assert.equal(await page.isHidden('#devices'), true, 'no Modbus devices (admin) for a viewer');
    assert.match(await page.textContent('[data-testid="role-status"]'), /role viewer/);
    const forced = await fetch(`${server.base}/api/v1/measurements`, { method: 'POST', headers: { Authorization: `Bearer ${viewer}`, 'Content-Type': 'text/plain' }, body: dbbFile({ machine: MACHINE, timestamp: '2026-05-01T08:00:00Z' }) });
    assert.equal(forced.status, 403);
    await page.evaluate(() => {
      document.body.dataset.role = 'operator';
    });
    await page.setInputFiles('#upload-file', { name: 'viewer.txt', mimeType: 'text/plain', buffer: Buffer.from(dbbFile({ machine: MACHINE, timestamp: '2026-05-02T08:00:00Z' })) });
    await page.click('#upload-button');
    await page.waitForSelector('#upload-message [data-testid="role-refusal"]');
    assert.equal(await page.textContent('#upload-message [data-testid="role-refusal"]'), 'Your role (viewer) may not upload measurements.');
    assert.match(await page.textContent('#upload-message'), /operator/, 'the server\'s reason names the role needed');
    assert.equal((await api.get(`/api/v1/measurements?machine_id=${MACHINE}`)).total, 3, 'nothing stored');

    // An operator: the upload panel is shown and uploads.
    const operator = await makeToken(server, 'cell 4 operator', 'operator');
    await openAs(page, server, operator, 'operator');
    assert.equal(await page.isVisible('#upload-panel'), true);
    await page.setInputFiles('#upload-file', { name: 'operator.txt', mimeType: 'text/plain', buffer: Buffer.from(dbbFile({ machine: MACHINE, timestamp: '2026-05-03T08:00:00Z', shape: 1.5 })) });
    await page.click('#upload-button');
    await page.waitForSelector('#upload-message.success');
    assert.equal((await api.get(`/api/v1/measurements?machine_id=${MACHINE}`)).total, 4);
  });
});
