// Browser scenario: cancelling a job from its view. The server runs no jobs (--job-workers 0),
// so a submitted calibration stays queued: its view shows a Cancel button. Another engineer's
// click is refused with the server's reason and the job stays queued; a viewer is not shown
// the button; the owner's click cancels it, the view says so (by whom, no result) and the
// button goes; the machine's job history shows it cancelled. A discovery's view has the same
// button.
//   node tests/browser/dashboard/cancel.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { fixtures, outDir, repo, withDashboard } from '../lib/harness.mjs';

const MACHINE = JSON.parse(readFileSync(join(repo, 'tests/fixtures/pm600-like.json'), 'utf8'));

test('a queued job is cancelled from its view by its owner only', { timeout: 110_000 }, async () => {
  await withDashboard(
    'cancel',
    async ({ server, api, page }) => {
      const ids = [];
      for (const t of 'abc') {
        const f = `dbb_${t}_ccw.txt`;
        ids.push((await api.upload(readFileSync(join(fixtures, 'hexapod', f), 'utf8'), f)).id);
      }
      const token = async (role, name) => (await api.post('/api/v1/tokens', JSON.stringify({ name, role }))).token;
      const engineer = await token('engineer', 'bob');
      const viewer = await token('viewer', 'visitor');
      const { job_id: jobId } = await api.post('/api/v1/calibrations', JSON.stringify({ machine: MACHINE, measurement_ids: ids }));
      const openAs = async (secret, role, hash) => {
        await page.goto('about:blank');
        await page.goto(`${server.base}/#token=${encodeURIComponent(secret)}`);
        await page.waitForSelector(`body[data-ready="true"][data-role="${role}"]`);
        await page.evaluate((x) => {
          window.location.hash = x;
        }, hash);
      };

      // A viewer sees the queued job without the button.
      await openAs(viewer, 'viewer', `#/jobs/${jobId}`);
      await page.waitForSelector('#job-status[data-status="queued"]');
      await page.waitForSelector('#job-cancel:not([hidden])', { state: 'attached' });
      assert.equal(await page.isVisible('#job-cancel'), false, 'no Cancel button for a viewer');

      // Another engineer is shown the button; the server refuses and says why.
      await openAs(engineer, 'engineer', `#/jobs/${jobId}`);
      await page.waitForSelector('#job-status[data-status="queued"]');
      await page.click('#job-cancel');
      await page.waitForSelector('#job-cancel-status.error');
      const refusal = await page.textContent('#job-cancel-status');
      assert.match(refusal, /only the token that submitted the job, or an admin/);
      assert.match(refusal, /only its owner or an admin may cancel it/);
      assert.equal((await api.get(`/api/v1/jobs/${jobId}`)).status, 'queued');

      // The owner cancels it: the view says so, the button goes.
      await openAs(server.token, 'admin', `#/jobs/${jobId}`);
      await page.waitForSelector('#job-status[data-status="queued"]');
      assert.equal(await page.isVisible('#job-cancel'), true);
      await page.click('#job-cancel');
      await page.waitForSelector('#job-status[data-status="cancelled"] [data-testid="job-cancelled"]');
      assert.match(await page.textContent('#job-status'), /cancelled by token 'bootstrap' \(id 1\)\. No result\./);
      assert.equal(await page.isVisible('#job-cancel'), false);
      assert.equal(await page.isVisible('#job-cancel-status'), false, 'no error left');
      const job = await api.get(`/api/v1/jobs/${jobId}`);
      assert.equal(job.status, 'cancelled');
      assert.equal(job.verdict, null);
      await page.waitForSelector(`[data-testid="job-item"][data-job-id="${jobId}"] .badge.job-cancelled`);
      await page.locator('#job-view').screenshot({ path: join(outDir, 'views-job-cancelled.png') });

      // A discovery's view has the same button.
      const { job_id: discId } = await api.post('/api/v1/discoveries', JSON.stringify({ measurement_ids: ids }));
      await page.evaluate((x) => {
        window.location.hash = x;
      }, `#/discoveries/${discId}`);
      await page.waitForSelector('#disc-status[data-status="queued"]');
      await page.click('#disc-cancel');
      await page.waitForSelector('#disc-status[data-status="cancelled"] [data-testid="job-cancelled"]');
      assert.equal(await page.isVisible('#disc-cancel'), false);
      assert.equal((await api.get(`/api/v1/jobs/${discId}`)).status, 'cancelled');
    },
    { serverArgs: ['--job-workers', '0'] },
  );
});
