// Browser test of the kinemetric dashboard (web/static) against the real kinemetricd:
// a laser-tracker upload: volumetric error vectors in XY and XZ, the decomposition table and the
// geometric error components. Compares what is drawn with the API's numbers and takes screenshots.
//
//   node tests/browser/dashboard/dashboard_tracker.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]
//
// (session.mjs: the server, the browser, the environment.)

import assert from 'node:assert/strict';
import { join } from 'node:path';
import {
  outDir, fixtures, TRACKER_FIXTURE, TRACKER_MACHINE, apiGet, um3, pathPoints, shown, unc2,
  runDashboard,
} from './session.mjs';

runDashboard('tracker', async ({ t, step, page, server }) => {
  await step('tracker upload: volumetric error vectors in XY and XZ, decomposition, figures', async () => {
    await page.setInputFiles('#upload-file', join(fixtures, TRACKER_FIXTURE));
    await page.click('#upload-button');
    const msg = await page.waitForSelector(`#upload-message.success:has-text("${TRACKER_FIXTURE}")`);
    const m = (await msg.textContent()).match(/#(\d+)/);
    assert.ok(m, 'success message names the id');
    const id = Number(m[1]);
    await page.waitForSelector(`#machines button[data-machine-id="${TRACKER_MACHINE}"][aria-current="true"]`);
    await page.waitForSelector(`#measurements a[data-id="${id}"][aria-current="true"]`);
    await page.waitForSelector('#polar-plot svg[data-testid="tracker-vector-plot"]');
    await page.waitForSelector('#figures table[data-kind="tracker"]');
    assert.equal(await page.isHidden('#analysis'), true, 'no DBB diagnosis for a tracker measurement');
    assert.equal(await page.isHidden('#calibration'), true, 'no hexapod panel without DBB tests');
    const [meas, res] = await Promise.all([
      apiGet(server, `/api/v1/measurements/${id}`),
      apiGet(server, `/api/v1/measurements/${id}/results`),
    ]);
    assert.equal(meas.kind, 'tracker');
    const { x_mm: xs, y_mm: ys, z_mm: zs } = meas.samples;
    const errors = res.volumetric_error_um;
    assert.equal(xs.length, 64, '4×4×4 commanded points');
    assert.equal(errors.length, xs.length);
    const plot = await page.$eval('#polar-plot svg', (svg) => ({
      pxPerUm: Number(svg.dataset.pxPerUm),
      pxPerMm: Number(svg.dataset.pxPerMm),
      magnification: Number(svg.dataset.magnification),
      mag: svg.querySelector('[data-testid="tracker-magnification"]').textContent,
      bar: { um: Number(svg.querySelector('[data-testid="tracker-scale"]').dataset.barUm), px: Number(svg.querySelector('[data-testid="tracker-scale"]').dataset.barPx), text: svg.querySelector('[data-testid="tracker-scale"]').textContent },
      views: [...svg.querySelectorAll('g.view')].map((g) => g.dataset.view),
      dots: svg.querySelectorAll('g.view circle[data-point]').length,
      vectors: [...svg.querySelectorAll('line.vector[data-point]')].map((l) => ({
        view: l.dataset.view,
        i: Number(l.dataset.point),
        e1: l.dataset.e1Um,
        e2: l.dataset.e2Um,
        x1: Number(l.getAttribute('x1')),
        y1: Number(l.getAttribute('y1')),
        x2: Number(l.getAttribute('x2')),
        y2: Number(l.getAttribute('y2')),
      })),
    }));
    assert.deepEqual(plot.views, ['xy', 'xz']);
    assert.equal(plot.dots, 2 * xs.length, 'every commanded point in both views');
    // Hovering a point gives its position and error in numbers.
    const k = errors.findIndex((e) => Array.isArray(e));
    const hover = await page.textContent(`#polar-plot svg g.view[data-view="xy"] circle[data-hit-point="${k}"] title`);
    const e0 = errors[k];
    const f3 = (v) => v.toFixed(3).replace('-', '−');
    assert.equal(
      hover,
      `Point ${k + 1} at X ${f3(xs[k])}, Y ${f3(ys[k])}, Z ${f3(zs[k])} mm: error X ${f3(e0[0])}, Y ${f3(e0[1])}, Z ${f3(e0[2])} µm (${f3(Math.hypot(...e0))} µm)`,
    );
    // One Z layer at a time, and back to all.
    const layerZ = Math.max(...zs);
    await page.selectOption('[data-testid="tracker-layer"]', String(layerZ));
    await page.waitForSelector(`#polar-plot svg[data-testid="tracker-vector-plot"][data-layer="${layerZ}"]`);
    const inLayer = zs.filter((z) => z === layerZ).length;
    assert.equal(await page.locator('#polar-plot svg[data-testid="tracker-vector-plot"] g.view circle[data-point]').count(), 2 * inLayer);
    await page.selectOption('[data-testid="tracker-layer"]', 'all');
    await page.waitForSelector('#polar-plot svg[data-testid="tracker-vector-plot"][data-layer="all"]');
    assert.ok(plot.magnification >= 1000, `magnification ${plot.magnification}`);
    assert.equal(plot.pxPerUm, plot.magnification * 1e-3 * plot.pxPerMm);
    assert.match(plot.mag, new RegExp(`×${plot.magnification}\\b`));
    assert.ok(Math.abs(plot.bar.px - plot.bar.um * plot.pxPerUm) < 1e-9, 'scale bar length');
    assert.ok(plot.bar.px >= 40 && plot.bar.px <= 130, `scale bar ${plot.bar.px} px`);
    assert.match(plot.bar.text, new RegExp(`^${plot.bar.um} µm$`));
    const kept = errors.filter(Boolean).length;
    assert.ok(kept > 0 && kept <= xs.length, `${kept} points with an error`);
    const tol = 0.02 / plot.pxPerUm; // coordinates are kept to 0.01 px
    for (const [view, a, b, pos] of [['xy', 0, 1, ys], ['xz', 0, 2, zs]]) {
      const lines = plot.vectors.filter((v) => v.view === view);
      assert.equal(lines.length, kept, `${view}: one arrow per kept point`);
      const first = lines.find((v) => v.i === 0) || lines[0];
      for (const v of lines) {
        const e = errors[v.i];
        assert.ok(e, `point ${v.i} has an error`);
        // The arrow is the API's error to 3 decimals...
        assert.equal(um3(Number(v.e1)), um3(e[a]), `${view} point ${v.i} e${a}`);
        assert.equal(um3(Number(v.e2)), um3(e[b]), `${view} point ${v.i} e${b}`);
        assert.ok(Math.abs((v.x2 - v.x1) / plot.pxPerUm - e[a]) <= tol, `${view} arrow ${v.i} along ${a}`);
        assert.ok(Math.abs(-(v.y2 - v.y1) / plot.pxPerUm - e[b]) <= tol, `${view} arrow ${v.i} along ${b}`);
        // ...drawn at the commanded point (same mm scale in both directions, y up).
        assert.ok(Math.abs(v.x1 - first.x1 - (xs[v.i] - xs[first.i]) * plot.pxPerMm) < 0.02, `${view} x of point ${v.i}`);
        assert.ok(Math.abs(-(v.y1 - first.y1) - (pos[v.i] - pos[first.i]) * plot.pxPerMm) < 0.02, `${view} y of point ${v.i}`);
      }
    }
    // Decomposition table = results.decomposition, 3 decimals, ± σ.
    const dec = res.decomposition;
    const rows = await page.$$eval('[data-testid="decomposition-table"] tbody tr[data-key]', (trs) =>
      trs.map((tr) => ({ key: tr.dataset.key, value: tr.querySelector('td[data-key="value"]').textContent, sigma: tr.querySelector('td[data-key="sigma"]').textContent })),
    );
    const expected = [
      ...['x', 'y', 'z'].map((k) => [`scale_ppm.${k}`, dec.scale_ppm[k], dec.scale_sigma_ppm[k]]),
      ...['xy', 'yz', 'zx'].map((k) => [`squareness_um_per_m.${k}`, dec.squareness_um_per_m[k], dec.squareness_sigma_um_per_m[k]]),
    ];
    assert.deepEqual(rows.map((r) => r.key), expected.map((e) => e[0]));
    rows.forEach((r, i) => {
      assert.equal(r.value, um3(expected[i][1]), r.key);
      assert.equal(r.sigma, `± ${unc2(expected[i][2])}`, `${r.key} σ`);
    });
    // The fixture's squareness (XY 8 µm/m, ZX −5 µm/m) and Z scale (6 ppm) are recovered.
    assert.ok(Math.abs(Math.abs(dec.squareness_um_per_m.xy) - 8) < 1, `xy ${dec.squareness_um_per_m.xy}`);
    assert.ok(Math.abs(Math.abs(dec.squareness_um_per_m.zx) - 5) < 1, `zx ${dec.squareness_um_per_m.zx}`);
    assert.ok(Math.abs(dec.scale_ppm.z - 6) < 1, `scale z ${dec.scale_ppm.z}`);
    const cell = (key) => page.textContent(`#figures td[data-key="${key}"][data-id="${id}"]`);
    assert.equal(await cell('residual_rms_um'), um3(res.residual_rms_um));
    assert.equal(shown(await cell('condition_number')).toFixed(3), res.condition_number.toFixed(3));
    assert.equal(await cell('rejected_readings_count'), String(res.rejected_readings.length));
    await page.screenshot({ path: join(outDir, 'dashboard-tracker.png') });
  });

  await step('tracker: geometric error components along X, Y, Z (curves = decomposition terms)', async () => {
    // The tracker measurement of the previous step is still selected.
    const id = Number(await page.getAttribute('#measurements a[aria-current="true"]', 'data-id'));
    const res = await apiGet(server, `/api/v1/measurements/${id}/results`);
    const dec = res.decomposition;
    assert.ok(dec && Array.isArray(dec.terms), 'results carry a decomposition with terms');
    await page.waitForSelector('#polar-plot [data-testid="component-charts"] svg[data-testid="component-chart"]');
    const charts = await page.$$eval('#polar-plot svg[data-testid="component-chart"]', (svgs) =>
      svgs.map((svg) => ({
        axis: svg.dataset.axis,
        lo: Number(svg.dataset.loMm),
        hi: Number(svg.dataset.hiMm),
        pxPerUm: Number(svg.dataset.pxPerUm),
        zeroPx: Number(svg.dataset.zeroPx),
        zeroY: Number(svg.querySelector('[data-testid="component-zero"]')?.getAttribute('y1')),
        legend: svg.querySelector('[data-testid="component-legend"]')?.textContent || '',
        titles: [...svg.querySelectorAll('text.axis-title')].map((t) => t.textContent),
        bands: svg.querySelectorAll('polygon, .band').length,
        curves: [...svg.querySelectorAll('g.components-curves path')].map((p) => ({
          direction: p.dataset.direction,
          kind: p.dataset.kind,
          pair: p.dataset.pair || null,
          ends: JSON.parse(p.dataset.endValues),
          d: p.getAttribute('d'),
        })),
      })),
    );
    assert.deepEqual(charts.map((c) => c.axis), ['x', 'y', 'z'], 'one component chart per axis');
    // Independent evaluation at the axis ends t = ±1, where P_k(±1) = (±1)^k (Legendre basis):
    //   positioning  E_AA = 1e-3·scale_ppm·(±h) + Σ c_k (±1)^k
    //   straightness E_BA = Σ c_k (±1)^k           squareness share in B: −½·1e-3·S_AB·(±h)
    const pairs = { xy: ['x', 'y'], yz: ['y', 'z'], zx: ['z', 'x'] };
    const checked = [];
    charts.forEach((c, i) => {
      const a = c.axis;
      const A = a.toUpperCase();
      const centre = dec.centre_mm[i];
      const half = dec.half_range_mm[i];
      assert.ok(half > 0, `${a} moves`);
      assert.ok(Math.abs(c.lo - (centre - half)) < 1e-9 && Math.abs(c.hi - (centre + half)) < 1e-9, `${a} range`);
      assert.ok(c.titles.includes(`${A} position (mm)`) && c.titles.includes('Error (µm)'), `${a} axis titles ${c.titles}`);
      assert.ok(Math.abs(c.zeroY - Math.round(c.zeroPx * 100) / 100) < 1e-9, `${a} zero line`);
      assert.equal(c.bands, 0, 'no ±1σ band (correlated terms, no covariance reported)');
      const solid = c.curves.filter((k) => k.kind !== 'squareness');
      assert.deepEqual(solid.map((k) => [k.direction, k.kind]).sort(), ['x', 'y', 'z'].map((b) => [b, b === a ? 'positioning' : 'straightness']));
      const shares = c.curves.filter((k) => k.kind === 'squareness');
      const wantPairs = Object.keys(pairs).filter((p) => pairs[p].includes(a) && !dec.fixed.some((f) => f.startsWith(`squareness_${p}`)));
      assert.deepEqual(shares.map((k) => k.pair).sort(), wantPairs.sort(), `${a} squareness shares`);
      for (const k of c.curves) {
        const b = k.direction;
        const expect = [-1, 1].map((sgn) => {
          if (k.kind === 'squareness') return -0.5e-3 * dec.squareness_um_per_m[k.pair] * sgn * half;
          let v = b === a ? 1e-3 * dec.scale_ppm[a] * sgn * half : 0;
          for (const t of dec.terms) if (t.axis === a && t.direction === b) v += t.value_um * sgn ** t.order;
          return v;
        });
        const tag = `${a}: E${b.toUpperCase()}${A} ${k.kind}${k.pair ? ` ${k.pair}` : ''}`;
        assert.equal(k.ends.length, 2, tag);
        k.ends.forEach((v, j) => assert.ok(Math.abs(v - expect[j]) < 1e-6, `${tag} end ${j}: drawn ${v}, from the terms ${expect[j]}`));
        // ...and that is what is drawn: first/last path vertex at the ends, µm → px.
        const pts = pathPoints(k.d);
        assert.ok(pts.length >= 50, `${tag} sampled`);
        for (const [j, pt] of [[0, pts[0]], [1, pts[pts.length - 1]]]) {
          assert.ok(Math.abs(c.zeroPx - pt[1] - expect[j] * c.pxPerUm) < 0.011, `${tag} end ${j} at ${pt[1]} px`);
        }
        checked.push(tag);
      }
      assert.match(c.legend, new RegExp(`E${A}${A} positioning`), `${a} legend`);
    });
    assert.equal(checked.length, 3 * 3 + 3 * 2, 'three curves and two squareness shares per axis');
    // The fixture's Z scale error (6 ppm) shows as the slope of E_ZZ: ≈ ±0.9 µm at z = ±150 mm.
    const ezz = charts[2].curves.find((k) => k.kind === 'positioning').ends;
    assert.ok(Math.abs(ezz[1] - ezz[0] - 1e-3 * 6 * 2 * dec.half_range_mm[2]) < 0.2, `E_ZZ ends ${ezz}`);
    // Uncertainty: no band, per-term σ in the table; fixed components named under the charts.
    const notes = await page.textContent('[data-testid="component-uncertainty"]');
    assert.match(notes, /uncertainty per term in the table/);
    const cells = await page.$$eval('[data-testid="component-terms"] tbody td[data-order]', (tds) =>
      tds.map((td) => ({ axis: td.closest('tr').dataset.axis, direction: td.closest('tr').dataset.direction, order: Number(td.dataset.order), key: td.dataset.key, text: td.textContent })),
    );
    const cell = (t, key) => cells.find((c) => c.axis === t.axis && c.direction === t.direction && c.order === t.order && c.key === key)?.text;
    for (const t of dec.terms) {
      assert.equal(cell(t, 'value'), um3(t.value_um), `term ${t.axis}${t.direction} order ${t.order}`);
      assert.equal(cell(t, 'sigma'), `± ${unc2(t.sigma_um)}`, `σ of term ${t.axis}${t.direction} order ${t.order}`);
    }
    assert.equal(cells.filter((c) => c.key === 'value' && c.text !== '—').length, dec.terms.length, 'one table cell per term');
    const fixedBox = await page.$eval('[data-testid="component-charts"]', (box) => ({
      text: box.textContent,
      items: [...box.querySelectorAll('[data-testid="component-fixed"] li')].map((li) => li.textContent),
    }));
    assert.deepEqual(fixedBox.items, dec.fixed);
    assert.match(fixedBox.text, /not identifiable from this map \(held at zero\)/i);
    const box = await page.$('[data-testid="component-charts"]');
    await box.scrollIntoViewIfNeeded();
    await box.screenshot({ path: join(outDir, 'dashboard-tracker-components.png') });
  });

});
