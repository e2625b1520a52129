// Browser test of the kinemetric dashboard (web/static) against the real kinemetricd:
// straightness, flatness and parallelism uploads with their plots and figures, and a laser
// positioning test (ISO 230-2 chart). Compares what is drawn with the API's numbers and takes
// screenshots.
//
//   node tests/browser/dashboard/dashboard_form.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]
//
// (session.mjs: the server, the browser, the environment.)

import assert from 'node:assert/strict';
import { join } from 'node:path';
import {
  outDir, fixtures, FORM_FIXTURES, apiGet, um3, shown, runDashboard, repo,
} from './session.mjs';

runDashboard('form', async ({ step, page, server }) => {
  const formIds = {};
  const uploadForm = async (kind) => {
    await page.setInputFiles('#upload-file', join(fixtures, FORM_FIXTURES[kind]));
    await page.click('#upload-button');
    const msg = await page.waitForSelector(`#upload-message.success:has-text("${FORM_FIXTURES[kind]}")`);
    const m = (await msg.textContent()).match(/#(\d+)/);
    assert.ok(m, 'success message names the id');
    formIds[kind] = Number(m[1]);
    await page.waitForSelector(`#measurements a[data-id="${formIds[kind]}"][aria-current="true"]`);
    await page.waitForSelector(`#figures table[data-kind="${kind}"]`);
    assert.equal(await page.isHidden('#analysis'), true, 'no DBB diagnosis for a form measurement');
    const [meas, res] = await Promise.all([
      apiGet(server, `/api/v1/measurements/${formIds[kind]}`),
      apiGet(server, `/api/v1/measurements/${formIds[kind]}/results`),
    ]);
    assert.equal(meas.kind, kind);
    const cell = (key) => page.textContent(`#figures td[data-key="${key}"][data-id="${formIds[kind]}"]`);
    return { meas, res, cell };
  };

  await step('straightness upload: profile about the LS line, minimum zone, figures', async () => {
    const { meas, res, cell } = await uploadForm('straightness');
    await page.waitForSelector('#polar-plot svg[data-testid="profile-plot"]');
    for (const k of ['straightness_lsq_um', 'straightness_min_zone_um', 'straightness_end_point_um', 'slope_um_per_m']) {
      assert.equal(await cell(k), um3(res[k]), k);
    }
    // The fixture: slope 12 µm/m plus the bow's zero net slope; waviness 55 mm, 0.2 µm.
    assert.ok(Math.abs(res.slope_um_per_m - 12) < 0.5, `slope ${res.slope_um_per_m}`);
    const wave = res.periodic.find((p) => Math.abs(p.period_mm - 55) < 2);
    assert.ok(wave && Math.abs(wave.amplitude_um - 0.2) < 0.03, `55 mm waviness: ${JSON.stringify(res.periodic)}`);
    const periodicRows = await page.$$eval('[data-testid="periodic-table"] tbody tr[data-index]', (trs) =>
      trs.map((tr) => Object.fromEntries([...tr.querySelectorAll('td')].map((td) => [td.dataset.key, td.textContent]))),
    );
    assert.equal(periodicRows.length, res.periodic.length);
    res.periodic.forEach((p, i) => {
      assert.equal(periodicRows[i].period_mm, um3(p.period_mm));
      assert.equal(periodicRows[i].amplitude_um, um3(p.amplitude_um));
      assert.equal(periodicRows[i].peak_to_valley_um, um3(2 * p.amplitude_um));
    });
    const plot = await page.$eval('#polar-plot svg', (svg) => ({
      points: Number(svg.querySelector('[data-testid="profile-trace"]').dataset.points),
      ls: svg.querySelectorAll('[data-testid="ls-line"]').length,
      zone: svg.querySelector('[data-testid="min-zone-band"]')?.dataset.widthUm,
      text: svg.textContent,
    }));
    assert.equal(plot.points, meas.samples.position_mm.length);
    assert.equal(plot.points, 201);
    assert.equal(plot.ls, 1, 'least-squares zero line');
    assert.ok(plot.zone !== undefined, 'minimum-zone band drawn');
    assert.ok(Math.abs(Number(plot.zone) - res.straightness_min_zone_um) < 1e-3, `zone ${plot.zone} vs ${res.straightness_min_zone_um}`);
    assert.match(plot.text, /Position along X \(mm\)/);
    assert.match(plot.text, /\(µm\)/);
    await page.screenshot({ path: join(outDir, 'dashboard-straightness.png') });
  });

  await step('flatness upload: colour map about the LS plane with a µm scale, figures', async () => {
    const { meas, res, cell } = await uploadForm('flatness');
    await page.waitForSelector('#polar-plot svg[data-testid="flatness-map"]');
    for (const k of ['flatness_lsq_um', 'flatness_min_zone_um', 'range_um']) assert.equal(await cell(k), um3(res[k]), k);
    for (const k of ['slope_x_um_per_m', 'slope_y_um_per_m', 'offset_um']) assert.equal(await cell(`plane.${k}`), um3(res.plane[k]), k);
    const cells = await page.$$eval('#polar-plot svg .cells [data-um]', (cs) =>
      cs.map((c) => ({ x: Number(c.dataset.xMm), y: Number(c.dataset.yMm), um: Number(c.dataset.um), fill: c.getAttribute('fill') })),
    );
    const { x_mm: xs, y_mm: ys, z_um: zs } = meas.samples;
    assert.equal(cells.length, zs.length);
    assert.equal(cells.length, 63);
    const p = res.plane;
    for (let i = 0; i < zs.length; ++i) {
      const c = cells.find((q) => q.x === xs[i] && q.y === ys[i]);
      const expectUm = zs[i] - (p.offset_um + (p.slope_x_um_per_m / 1000) * xs[i] + (p.slope_y_um_per_m / 1000) * ys[i]);
      assert.ok(c && Math.abs(c.um - expectUm) < 1e-9, `cell ${xs[i]},${ys[i]}`);
    }
    // Peak to valley of the drawn deviations is the least-squares flatness.
    const pv = Math.max(...cells.map((c) => c.um)) - Math.min(...cells.map((c) => c.um));
    assert.ok(Math.abs(pv - res.flatness_lsq_um) < 1e-6, `${pv} vs ${res.flatness_lsq_um}`);
    assert.ok(new Set(cells.map((c) => c.fill)).size > 5, 'colours vary');
    const scale = await page.textContent('#polar-plot [data-testid="colour-scale"]');
    assert.match(scale, /µm/);
    await page.screenshot({ path: join(outDir, 'dashboard-flatness.png') });
  });

  await step('parallelism upload: readings from the datum with the LS line, figures', async () => {
    const { meas, res, cell } = await uploadForm('parallelism');
    await page.waitForSelector('#polar-plot svg[data-testid="profile-plot"]');
    for (const k of ['parallelism_um', 'slope_um_per_m', 'straightness_lsq_um']) assert.equal(await cell(k), um3(res[k]), k);
    const band = await page.$eval('#polar-plot [data-testid="parallelism-band"]', (b) => Number(b.dataset.widthUm));
    const d = meas.samples.deviation_um;
    assert.ok(Math.abs(band - res.parallelism_um) < 1e-9);
    assert.ok(Math.abs(Math.max(...d) - Math.min(...d) - res.parallelism_um) < 1e-9);
    await page.screenshot({ path: join(outDir, 'dashboard-parallelism.png') });
  });
  await step('laser positioning upload: mean ±2s bands of both directions, every run, A B E M R', async () => {
    const file = 'positioning_x.txt';
    await page.setInputFiles('#upload-file', join(repo, 'data/examples', file));
    await page.click('#upload-button');
    const msg = await page.waitForSelector(`#upload-message.success:has-text("${file}")`);
    const id = Number((await msg.textContent()).match(/#(\d+)/)[1]);
    await page.waitForSelector(`#figures table[data-kind="positioning"]`);
    await page.waitForSelector('#polar-plot svg[data-testid="positioning-plot"]');
    const res = await apiGet(server, `/api/v1/measurements/${id}/results`);
    const plot = await page.$eval('#polar-plot svg', (svg) => ({
      targets: Number(svg.dataset.targets),
      runs: Number(svg.dataset.runs),
      runLines: svg.querySelectorAll('.run-line').length,
      up: JSON.parse(svg.querySelector('[data-testid="mean-up"]').dataset.values),
      down: JSON.parse(svg.querySelector('[data-testid="mean-down"]').dataset.values),
      bandUp: JSON.parse(svg.querySelector('[data-testid="band-up"]').dataset.widthUm),
      text: svg.querySelector('[data-testid="positioning-figures"]').textContent,
    }));
    assert.equal(plot.targets, res.targets.target_mm.length);
    assert.equal(plot.runs, 2 * res.runs, 'one faint line per run and direction');
    assert.equal(plot.runLines, plot.runs);
    assert.deepEqual(plot.up, res.targets.mean_up_um);
    assert.deepEqual(plot.down, res.targets.mean_down_um);
    res.targets.s_up_um.forEach((s, i) => assert.ok(Math.abs(plot.bandUp[i] - 4 * s) < 1e-12));
    for (const [letter, key] of [['A', 'accuracy_um'], ['B', 'reversal_value_um'], ['E', 'systematic_deviation_um'],
      ['M', 'mean_deviation_range_um'], ['R', 'repeatability_um']]) {
      assert.ok(plot.text.includes(`${letter} ${res[key].toFixed(2)} µm`), `${letter} on the chart: ${plot.text}`);
    }
    const cell = (key) => page.textContent(`#figures td[data-key="${key}"][data-id="${id}"]`);
    assert.equal(await cell('accuracy_um'), um3(res.accuracy_um));
    assert.match(await page.textContent('#plot-note'), /air: n = 1\.000/);
    await page.screenshot({ path: join(outDir, 'dashboard-positioning.png') });
  });
});
