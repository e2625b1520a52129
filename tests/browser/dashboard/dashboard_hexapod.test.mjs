// Browser test of the kinemetric dashboard (web/static) against the real kinemetricd:
// a hexapod calibration job run from the "Calibrate hexapod" panel: before/after circularity and
// identified parameters = the job's result. Compares what is drawn with the API's numbers and
// takes screenshots.
//
//   node tests/browser/dashboard/dashboard_hexapod.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]
//
// (session.mjs: the server, the browser, the environment.)

import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import {
  outDir, fixtures, HEXAPOD_FIXTURES, HEXAPOD_MACHINE_JSON, HEXAPOD_MACHINE, apiGet, um3, shown,
  unc2, runDashboard,
} from './session.mjs';

runDashboard('hexapod', async ({ t, step, page, server, pageErrors }) => {
  await step('hexapod: upload DBB tests, calibrate from the panel, before/after table', async () => {
    const hexIds = [];
    for (const f of HEXAPOD_FIXTURES) {
      const r = await fetch(`${server.base}/api/v1/measurements`, {
        method: 'POST',
        body: readFileSync(join(fixtures, f)),
        headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': 'text/plain', 'X-Filename': f.split('/').pop() },
      });
      assert.equal(r.status, 201, `upload ${f}`);
      hexIds.push((await r.json()).id);
    }
    await page.click('#machines-refresh');
    await page.click(`#machines button[data-machine-id="${HEXAPOD_MACHINE}"]`);
    await page.waitForSelector(`#machines button[data-machine-id="${HEXAPOD_MACHINE}"][aria-current="true"]`);
    await page.waitForSelector('#calibration:not([hidden])');
    const choices = await page.$$eval('#calib-measurements input[data-testid="calib-choice"]', (bs) => bs.map((b) => Number(b.dataset.id)));
    assert.deepEqual(choices, [...hexIds].sort((a, b) => a - b));
    // Without a machine file the panel says so and submits nothing.
    await page.click('#calib-all');
    await page.click('#calib-run');
    await page.waitForSelector('#calib-status.error:has-text("machine definition")');
    await page.setInputFiles('#calib-machine-file', HEXAPOD_MACHINE_JSON);
    await page.selectOption('#calib-method', 'absolute');
    const t0 = Date.now();
    await page.click('#calib-run');
    // The job's page (#/jobs/{id}) follows it to the end; the server's verdict is ok.
    await page.waitForSelector('#job-view:not([hidden])[data-job-verdict="ok"]', { timeout: 60_000 });
    t.diagnostic(`calibration job took ${Date.now() - t0} ms`);
    const jobId = Number(await page.getAttribute('#job-view', 'data-job-id'));
    const job = await apiGet(server, `/api/v1/jobs/${jobId}`);
    assert.equal(job.status, 'done');
    assert.deepEqual(job.request.measurement_ids, [...hexIds].sort((a, b) => a - b));
    assert.equal(job.request.method, 'absolute');
    const res = job.result;
    const rows = await page.$$eval('[data-testid="calib-tests-table"] tbody tr', (trs) =>
      trs.map((tr) => Object.fromEntries([...tr.querySelectorAll('td')].map((td) => [td.dataset.key, td.textContent]))),
    );
    assert.equal(rows.length, res.tests.length);
    assert.equal(rows.length, HEXAPOD_FIXTURES.length);
    res.tests.forEach((tt, i) => {
      assert.equal(rows[i].test_id, tt.test_id);
      assert.equal(rows[i].direction, tt.direction.toUpperCase());
      assert.equal(rows[i].circularity_before_um, um3(tt.circularity_before_um), `before ${tt.test_id}`);
      assert.equal(rows[i].predicted_circularity_after_um, um3(tt.predicted_circularity_after_um), `after ${tt.test_id}`);
      for (const k of ['centre_deviation_before_um', 'centre_deviation_predicted_after_um',
                       'average_radial_error_before_um', 'average_radial_error_predicted_after_um']) {
        assert.equal(rows[i][k], um3(tt[k]), `${k} ${tt.test_id}`);
      }
    });
    // The simulated machine is off its nominal geometry: the correction must help.
    const meanOf = (k) => res.tests.reduce((s, tt) => s + tt[k], 0) / res.tests.length;
    assert.ok(meanOf('predicted_circularity_after_um') < 0.5 * meanOf('circularity_before_um'), 'predicted improvement');
    const params = await page.$$eval('[data-testid="calib-params-table"] td[data-param]', (tds) =>
      Object.fromEntries(tds.map((td) => [td.dataset.param, { text: td.textContent, fixed: td.classList.contains('fixed') }])),
    );
    assert.equal(Object.keys(params).length, 24);
    const fixedSet = new Set(res.fixed_parameters);
    for (let j = 0; j < 6; ++j) {
      const check = (name, v, u) => {
        const want = fixedSet.has(name) ? `${um3(v)} (fixed)` : `${um3(v)} ± ${unc2(u)}`;
        assert.equal(params[name].text, want, name);
        assert.equal(params[name].fixed, fixedSet.has(name), `${name} fixed mark`);
      };
      check(`strut_offset_um[${j}]`, res.parameters.strut_offset_um[j], res.parameter_uncertainty_um.strut_offset_um[j]);
      for (let c = 0; c < 3; ++c) {
        check(`base_joint_offset_um[${j}][${c}]`, res.parameters.base_joint_offset_um[j][c], res.parameter_uncertainty_um.base_joint_offset_um[j][c]);
      }
    }
    assert.equal(await page.textContent('[data-testid="calib-summary"] dd[data-key="residual_rms_um"]'), `${um3(res.residual_rms_um)} µm`);
    assert.equal(shown(await page.textContent('[data-testid="calib-summary"] dd[data-key="condition_number"]')).toFixed(3), res.condition_number.toFixed(3));
    await page.locator('#job-view').scrollIntoViewIfNeeded();
    await page.screenshot({ path: join(outDir, 'dashboard-hexapod.png') });
    const overflow = await page.evaluate(() => document.documentElement.scrollWidth);
    assert.ok(overflow <= 1280, `no horizontal scrolling (scrollWidth ${overflow})`);
    assert.deepEqual(pageErrors, []);
  });

});
