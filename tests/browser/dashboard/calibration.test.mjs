// Browser scenario: a calibration from one DBB test is under-determined:
// the server's job JSON says "warning" with its reasons, and the job view (#/jobs/{id}) shows
// them with no predicted "after" figures and no corrected machine file; fixed parameters are
// named in words. A calibration from ten tests is "ok": after figures and the corrected machine
// file for download. Both are in the machine's job history; a reload keeps the job view. The
// hexapod panel is shown for the hexapod only, not for a serial machine.
//   node tests/browser/dashboard/calibration.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { assertNoHorizontalOverflow, dbbFile, fixtures, outDir, repo, withDashboard } from '../lib/harness.mjs';

const MACHINE_JSON = join(repo, 'tests/fixtures/pm600-like.json');
const HEXAPOD = 'pm600-like';

test('one-test calibration: warning, reasons, no after figures; ten tests: ok', { timeout: 110_000 }, async () => {
  await withDashboard('calibration', async ({ api, page, open }) => {
    const ids = [];
    for (const t of 'abcdefghij') {
      const f = `dbb_${t}_ccw.txt`;
      ids.push((await api.upload(readFileSync(join(fixtures, 'hexapod', f), 'utf8'), f)).id);
    }
    await api.upload(dbbFile({ machine: 'serial-vmc', direction: 'ccw', timestamp: '2026-05-01T08:00:00Z' }), 'serial.txt');

    // A serial machine has no hexapod panel.
    await open('#/machines/serial-vmc');
    await page.waitForSelector('#detail[data-view="dbb"]');
    assert.equal(await page.isHidden('#calibration'), true, 'no hexapod panel for a serial machine');

    await page.evaluate((m) => {
      window.location.hash = `#/machines/${m}`;
    }, HEXAPOD);
    await page.waitForSelector('#calibration:not([hidden])');
    await page.check(`#calib-measurements input[data-id="${ids[0]}"]`);
    await page.setInputFiles('#calib-machine-file', MACHINE_JSON);
    await page.click('#calib-run');
    await page.waitForSelector('#job-view:not([hidden])[data-job-verdict="warning"]', { timeout: 60_000 });
    const jobId = Number(await page.getAttribute('#job-view', 'data-job-id'));
    assert.match(page.url(), new RegExp(`#/jobs/${jobId}$`));
    const job = await api.get(`/api/v1/jobs/${jobId}`);
    assert.equal(job.status, 'done');
    assert.equal(job.verdict, 'warning');
    assert.ok(job.verdict_reasons.length >= 2, JSON.stringify(job.verdict_reasons));
    // The page shows the server's verdict and every reason, and no confident "after" figures.
    assert.equal(await page.getAttribute('[data-testid="job-verdict"]', 'data-verdict'), 'warning');
    const reasons = await page.$$eval('[data-testid="verdict-reason"]', (li) => li.map((x) => x.textContent));
    assert.deepEqual(reasons, job.verdict_reasons);
    assert.ok(reasons.some((r) => /ill-conditioned|under-determined/.test(r)), reasons.join(' | '));
    assert.equal(await page.getAttribute('[data-testid="calib-tests-table"]', 'data-after'), 'withheld');
    assert.equal(await page.locator('[data-testid="calib-tests-table"] [data-key="predicted_circularity_after_um"]').count(), 0);
    assert.equal(await page.locator('[data-testid="job-download-machine"]').count(), 0);
    assert.doesNotMatch(await page.textContent('#job-view'), /Calibration finished/);
    // Fixed parameters in words, every letter kept.
    const fixedText = await page.textContent('[data-testid="calib-summary"] dd[data-key="fixed_parameters"]');
    if (job.result.fixed_parameters.length) {
      assert.match(fixedText, /^(Strut \d length offset|Base joint \d [XYZ])(, (Strut \d length offset|Base joint \d [XYZ]))*$/, fixedText);
      assert.doesNotMatch(fixedText, /_um|\[/);
    } else {
      assert.equal(fixedText, 'none');
    }
    const ddBox = await page.locator('[data-testid="calib-summary"] dd[data-key="fixed_parameters"]').boundingBox();
    const dlBox = await page.locator('[data-testid="calib-summary"]').boundingBox();
    assert.ok(ddBox.x >= dlBox.x, 'the wrapped value starts inside the summary (no clipped first letter)');
    await page.locator('#job-view').screenshot({ path: join(outDir, 'views-calibration-warning.png') });

    // Reload keeps the job view.
    await page.reload();
    await page.waitForSelector(`#job-view:not([hidden])[data-job-id="${jobId}"][data-job-verdict="warning"]`);

    // Ten tests: ok, with the after figures and the corrected machine file.
    await page.evaluate((m) => {
      window.location.hash = `#/machines/${m}`;
    }, HEXAPOD);
    await page.waitForSelector('#calibration:not([hidden])');
    await page.click('#calib-all');
    await page.setInputFiles('#calib-machine-file', MACHINE_JSON);
    await page.selectOption('#calib-method', 'absolute');
    await page.click('#calib-run');
    await page.waitForSelector(`#job-view:not([hidden]):not([data-job-id="${jobId}"])[data-job-verdict="ok"]`, { timeout: 60_000 });
    const okId = Number(await page.getAttribute('#job-view', 'data-job-id'));
    const okJob = await api.get(`/api/v1/jobs/${okId}`);
    assert.equal(okJob.verdict, 'ok');
    assert.deepEqual(okJob.verdict_reasons, []);
    const after = await page.$$eval('[data-testid="calib-tests-table"] td[data-key="predicted_circularity_after_um"]', (tds) => tds.map((td) => td.textContent));
    assert.equal(after.length, 10);
    okJob.result.tests.forEach((t, i) => assert.equal(after[i], t.predicted_circularity_after_um.toFixed(3).replace('-', '−')));
    // The figures' units are said (the calibration's DBB figures are the bar's).
    assert.ok(okJob.result.tests.every((t) => t.deviation_units === 'bar'));
    assert.match(await page.textContent('[data-testid="calib-units"]'), /bar units/);
    const [download] = await Promise.all([page.waitForEvent('download'), page.click('[data-testid="job-download-machine"]')]);
    const machine = JSON.parse(readFileSync(await download.path(), 'utf8'));
    assert.deepEqual(machine, okJob.result.calibrated_machine, 'the corrected machine file is the job\'s');

    // The machine's job history lists both, with their verdicts, newest first.
    await page.waitForSelector(`[data-testid="job-item"][data-job-id="${okId}"][data-verdict="ok"]`);
    const history = await page.$$eval('[data-testid="job-item"]', (as) => as.map((a) => [Number(a.dataset.jobId), a.dataset.verdict]));
    assert.deepEqual(history, [[okId, 'ok'], [jobId, 'warning']]);
    const apiHistory = await api.get(`/api/v1/jobs?machine_id=${HEXAPOD}`);
    assert.deepEqual(apiHistory.items.map((j) => j.id), [okId, jobId]);
    assert.deepEqual((await api.get('/api/v1/jobs?machine_id=serial-vmc')).items, []);
    // 400 px wide: the job view with its tables fits (the tables scroll inside themselves).
    await page.setViewportSize({ width: 400, height: 800 });
    await assertNoHorizontalOverflow(page, '400 px, calibration job');
    await page.setViewportSize({ width: 1280, height: 900 });

    // Back to the warning job from the history.
    await page.click(`[data-testid="job-item"][data-job-id="${jobId}"]`);
    await page.waitForSelector(`#job-view[data-job-id="${jobId}"][data-job-verdict="warning"]`);
  });
});
