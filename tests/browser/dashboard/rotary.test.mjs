// Browser scenario of a rotary-axis R-test (issue 41, "In the service"): the example file
// data/examples/rotary_ac-trunnion.txt uploaded through the page's upload form; its view shows
// the eight location errors with σ in a table (the API's values), the rank and RMS sentence and
// the chart of the displacement per pose before and after the fit, with the per-pose table; at
// 1366 and 400 px, no console error, no failed request, no sideways scroll.
//
//   node tests/browser/dashboard/rotary.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import assert from 'node:assert/strict';
import { test } from 'node:test';
import { join } from 'node:path';
import { assertNoHorizontalOverflow, outDir, repo, withDashboard } from '../lib/harness.mjs';

const EXAMPLE = 'rotary_ac-trunnion.txt';
const fixed2 = (v) => v.toFixed(2).replace('-', '−');

test('rotary: location errors with σ, the displacement per pose before and after the fit', { timeout: 170_000 }, async () => {
  await withDashboard('rotary', async ({ api, page, open }) => {
    const failed = [];
    page.on('response', (r) => {
      if (r.status() >= 400 && !/\/tolerances$/.test(new URL(r.url()).pathname)) failed.push(`${r.status()} ${r.url()}`);
    });
    page.on('requestfailed', (req) => failed.push(`failed ${req.url()}`));
    await open();
    await page.setInputFiles('#upload-file', join(repo, 'data/examples', EXAMPLE));
    await page.click('#upload-button');
    const msg = await page.waitForSelector(`#upload-message.success:has-text("${EXAMPLE}")`);
    const id = Number((await msg.textContent()).match(/#(\d+)/)[1]);
    const res = await api.get(`/api/v1/measurements/${id}/results`);
    assert.equal(res.kinematics, 'AC-trunnion');
    assert.equal(res.rank, 8);
    for (const width of [1366, 400]) {
      await page.setViewportSize({ width, height: 900 });
      await open(`#/measurements/${id}`);
      await page.waitForSelector(`#detail[data-measurement-id="${id}"] [data-testid="rotary-view"]`);
      const rows = await page.$$eval('[data-testid="rotary-errors"] tbody tr', (trs) => trs.map((tr) => ({ name: tr.dataset.error, cells: [...tr.querySelectorAll('td')].map((c) => c.textContent) })));
      assert.deepEqual(rows.map((r) => r.name), ['YOA', 'ZOA', 'BOA', 'COA', 'XOC', 'YOC', 'AOC', 'BOC']);
      for (const r of rows) {
        const key = Object.keys(res.location_errors).find((k) => k.startsWith(`${r.name}_`));
        const e = res.location_errors[key];
        assert.equal(r.cells[0], fixed2(e.value), `${r.name} value`);
        assert.equal(r.cells[1], `± ${fixed2(e.sigma)}`, `${r.name} σ`);
        assert.equal(r.cells[2], key.endsWith('_urad') ? 'µrad' : 'µm');
      }
      assert.match(await page.textContent('[data-testid="rotary-rank"]'), /Rank of the pose set 8 of 8/);
      // The same measurement is opened again at the second width: wait for its chart to be laid
      // out (a slow server, e.g. under the sanitizers, answers after the view has been replaced).
      await page.waitForFunction(() => {
        const svg = document.querySelector('[data-testid="rotary-pose-chart"]');
        return svg && svg.isConnected && svg.getBoundingClientRect().width > 0;
      });
      const chart = await page.$eval('[data-testid="rotary-pose-chart"]', (svg) => ({
        series: [...svg.querySelectorAll('polyline[data-series]')].map((p) => [p.dataset.series, p.getAttribute('points').trim().split(/\s+/).length]),
        width: svg.getBoundingClientRect().width,
      }));
      assert.deepEqual(chart.series, [['measured', res.poses], ['residual', res.poses]]);
      assert.ok(chart.width > 200 && chart.width <= width, `chart ${chart.width} px wide at ${width}`);
      // The per-pose table: measured and after the fit, dx dy dz.
      await page.click('.rotary-poses-table summary');
      assert.equal(await page.$$eval('[data-testid="rotary-poses"] tbody tr', (trs) => trs.length), res.poses);
      const second = await page.$$eval('[data-testid="rotary-poses"] tbody tr:nth-child(2) td', (tds) => tds.map((t) => t.textContent));
      assert.equal(second[3], fixed2(res.residuals[1].measured_um[0]));
      assert.equal(second[6], fixed2(res.residuals[1].residual_um[0]));
      await assertNoHorizontalOverflow(page, `rotary view at ${width} px`);
      await page.screenshot({ path: join(outDir, `rotary-${width}.png`), fullPage: true });
    }
    assert.deepEqual(failed, []);
  });
});
