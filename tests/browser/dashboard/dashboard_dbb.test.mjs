// Browser test of the kinemetric dashboard (web/static) against the real kinemetricd:
// upload CCW and CW DBB files through the form; the polar plot, figures table, ISO 230-4 and
// minimum-zone figures, the joint CW + CCW diagnosis, harmonics, the server's PNG plot, a bad
// file's message; the page fits 1280×800; a wrong token's 401 message and the recovery. Compares what is drawn with the API's numbers and takes
// screenshots.
//
//   node tests/browser/dashboard/dashboard_dbb.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]
//
// (session.mjs: the server, the browser, the environment.)

import assert from 'node:assert/strict';
import { existsSync, readFileSync } from 'node:fs';
import { join } from 'node:path';
import {
  here, outDir, fixtures, MACHINE, TEST_ID, apiGet, um3, pathPoints, fixed1, unc2, valueText,
  badLineOf, runDashboard,
} from './session.mjs';

runDashboard('dbb', async ({ t, step, browser, page, server }) => {
  const ids = {};
  for (const dir of ['ccw', 'cw']) {
    await step(`upload the ${dir.toUpperCase()} file through the form`, async () => {
      await page.setInputFiles('#upload-file', join(fixtures, `dbb_xy-r150_${dir}.txt`));
      await page.click('#upload-button');
      const msg = await page.waitForSelector('#upload-message.success');
      const text = await msg.textContent();
      const m = text.match(/#(\d+)/);
      assert.ok(m, `success message names the measurement id: "${text}"`);
      ids[dir] = Number(m[1]);
      assert.match(text, /Uploaded “dbb_xy-r150_/);
      // The dashboard shows the uploaded file's machine and selects the measurement.
      await page.waitForSelector(`#machines button[data-machine-id="${MACHINE}"][aria-current="true"]`);
      await page.waitForSelector(`#measurements a[data-id="${ids[dir]}"][aria-current="true"]`);
      await page.waitForSelector(`#polar-plot svg path[data-direction="${dir}"]`);
    });
  }

  await step('measurement list holds both directions of the test', async () => {
    const items = await page.$$eval('#measurements a[data-testid="measurement-item"]', (bs) =>
      bs.map((b) => ({ id: Number(b.dataset.id), test: b.dataset.testId, dir: b.dataset.direction, kind: b.dataset.kind })),
    );
    assert.equal(items.length, 2, JSON.stringify(items));
    assert.deepEqual(
      items.map((i) => `${i.kind}/${i.test}/${i.dir}/${i.id}`).sort(),
      [`dbb/${TEST_ID}/ccw/${ids.ccw}`, `dbb/${TEST_ID}/cw/${ids.cw}`].sort(),
    );
    const machineText = await page.textContent(`#machines button[data-machine-id="${MACHINE}"]`);
    assert.match(machineText, /2 measurements/);
  });

  await step('polar plot overlays CCW and CW with legend, scale and magnification', async () => {
    // Select the CCW one explicitly: the CW partner must be overlaid too.
    await page.click(`#measurements a[data-id="${ids.ccw}"]`);
    await page.waitForSelector(`#measurements a[data-id="${ids.ccw}"][aria-current="true"]`);
    await page.waitForSelector('#polar-plot svg path[data-direction="ccw"]');
    await page.waitForSelector('#polar-plot svg path[data-direction="cw"]');
    const plot = await page.$eval('#polar-plot svg', (svg) => ({
      umPerDiv: Number(svg.dataset.umPerDiv),
      pxPerUm: Number(svg.dataset.pxPerUm),
      nominalPx: Number(svg.dataset.nominalPx),
      magnification: Number(svg.dataset.magnification),
      nominal: svg.querySelectorAll('circle.nominal').length,
      rings: [...svg.querySelectorAll('circle.ring')].map((c) => Number(c.dataset.ringUm)),
      legend: svg.querySelector('[data-testid="plot-legend"]').textContent,
      scale: svg.querySelector('[data-testid="plot-scale"]').textContent,
      mag: svg.querySelector('[data-testid="plot-magnification"]')?.textContent,
      paths: [...svg.querySelectorAll('path.trace')].map((p) => ({
        dir: p.dataset.direction,
        d: p.getAttribute('d'),
        stroke: p.getAttribute('stroke'),
        points: Number(p.dataset.points),
      })),
    }));
    assert.equal(plot.nominal, 1, 'nominal circle drawn');
    assert.ok(plot.rings.length >= 2 && plot.rings.some((r) => r > 0) && plot.rings.some((r) => r < 0), `±rings: ${plot.rings}`);
    assert.match(plot.legend, /CCW/);
    assert.match(plot.legend, /CW \(clockwise\)/);
    assert.match(plot.scale, /^Scale \d+(\.\d+)? µm\/div$/);
    assert.equal(plot.scale, `Scale ${plot.umPerDiv} µm/div`);
    assert.match(plot.mag ?? '', /^Magnification ×[\d\u2009]+$/);
    assert.equal(plot.paths.length, 2);
    assert.notEqual(plot.paths[0].stroke, plot.paths[1].stroke, 'two colours');

    // What is drawn is the API's trace: radius = R0 + e·k at the trace's angles.
    for (const p of plot.paths) {
      const trace = await apiGet(server, `/api/v1/measurements/${ids[p.dir]}/trace`);
      assert.equal(trace.direction, p.dir);
      const n = trace.angle_deg.length;
      assert.ok(n >= 360 && n <= 720, `one turn of samples: ${n}`);
      assert.equal(p.points, n);
      const pts = pathPoints(p.d);
      assert.equal(pts.length, n);
      const tol = 0.02 / plot.pxPerUm; // the SVG keeps 0.01 px
      let worst = 0;
      for (let i = 0; i < n; ++i) {
        const [x, y] = pts[i];
        const e = (Math.hypot(x, y) - plot.nominalPx) / plot.pxPerUm;
        worst = Math.max(worst, Math.abs(e - trace.radial_error_um[i]));
        const a = (trace.angle_deg[i] * Math.PI) / 180;
        if (Math.hypot(x, y) > 1) {
          const drawn = Math.atan2(-y, x);
          const da = Math.abs(Math.atan2(Math.sin(drawn - a), Math.cos(drawn - a)));
          assert.ok(da < 1e-3, `angle of point ${i}: ${drawn} vs ${a}`);
        }
      }
      assert.ok(worst < tol, `${p.dir}: drawn radial error matches the API within ${tol} µm (worst ${worst})`);
      // Scale: the largest error fits inside the rings.
      const maxAbs = Math.max(...trace.radial_error_um.map(Math.abs));
      assert.ok(maxAbs <= 3 * plot.umPerDiv, `max |e| ${maxAbs} within ±3 div of ${plot.umPerDiv}`);
      // Magnification = (px per µm of error) / (px per µm of the circle).
      const expectMag = (plot.pxPerUm * trace.radius_mm * 1000) / plot.nominalPx;
      assert.ok(Math.abs(plot.magnification - expectMag) < 0.01, `${plot.magnification} vs ${expectMag}`);
    }
  });

  await step('figures table shows the API results for both directions', async () => {
    await page.waitForSelector('#figures table');
    const headers = await page.$$eval('#figures table thead th', (ths) => ths.map((th) => th.textContent.trim()));
    assert.deepEqual(headers.slice(2), [`CCW #${ids.ccw}`, `CW #${ids.cw}`]);
    for (const dir of ['ccw', 'cw']) {
      const res = await apiGet(server, `/api/v1/measurements/${ids[dir]}/results`);
      const trace = await apiGet(server, `/api/v1/measurements/${ids[dir]}/trace`);
      const cell = (key) => page.textContent(`#figures td[data-key="${key}"][data-direction="${dir}"]`);
      assert.equal(await cell('test_id'), TEST_ID);
      assert.equal(await cell('direction'), dir.toUpperCase());
      assert.equal(res.mode, 'centre_corrected', 'no fixed_ball_mm in the fixture');
      assert.equal(await cell('mode'), 'centre corrected');
      assert.equal(await cell('centre_offset_x_um'), um3(res.centre_offset_um[0]));
      assert.equal(await cell('centre_offset_y_um'), um3(res.centre_offset_um[1]));
      assert.equal(await cell('average_radial_error_um'), um3(res.average_radial_error_um));
      assert.equal(await cell('circularity_um'), um3(res.circularity_um));
      // Every other top-level numeric key of the results has its row too.
      for (const [k, v] of Object.entries(res)) {
        if (typeof v === 'number') assert.ok((await cell(k)) !== null, `row for ${k}`);
      }
      if (typeof res.min_zone_circularity_um === 'number') {
        assert.equal(await cell('min_zone_circularity_um'), um3(res.min_zone_circularity_um));
      }
      // Consistency of the two endpoints (radius = bar length here, [PM-600 report] eq. 4.8):
      // circularity = max − min of the radial error about the fitted centre.
      const pv = Math.max(...trace.radial_error_um) - Math.min(...trace.radial_error_um);
      assert.ok(Math.abs(pv - res.circularity_um) < 0.01, `circularity ${res.circularity_um} vs trace p-v ${pv}`);
      // The fixture's offset (4, 2.5) µm comes from the 1st harmonic of dr; it is found
      // to well under a micrometre (it is the CW file's too).
      assert.ok(Math.abs(res.centre_offset_um[0] - 4.0) < 0.5, `offset x ${res.centre_offset_um[0]}`);
      assert.ok(Math.abs(res.centre_offset_um[1] - 2.5) < 0.5, `offset y ${res.centre_offset_um[1]}`);
    }
  });

  await step('ISO 230-4 and minimum-zone figures, pair hysteresis in the figures table', async () => {
    const pair = await apiGet(server, `/api/v1/measurements/${ids.ccw}/pair`);
    assert.equal(pair.partner_id, ids.cw, 'the CW file is the partner of the CCW file');
    for (const dir of ['ccw', 'cw']) {
      const res = await apiGet(server, `/api/v1/measurements/${ids[dir]}/results`);
      const cell = (key) => page.textContent(`#figures td[data-key="${key}"][data-direction="${dir}"]`);
      assert.equal(await cell('min_zone_circularity_um'), um3(res.min_zone_circularity_um));
      for (const k of ['circular_deviation_um', 'radial_deviation_max_um', 'radial_deviation_min_um']) {
        assert.equal(await cell(`iso230_4.${k}`), um3(res.iso230_4[k]), k);
      }
      // Minimum zone never exceeds the least-squares circularity.
      assert.ok(res.min_zone_circularity_um <= res.circularity_um + 1e-9);
    }
    const label = await page.textContent('#figures tr[data-key="iso230_4.circular_deviation_um"] th');
    assert.match(label, /ISO 230-4/);
    for (const k of ['circular_hysteresis_um', 'bidirectional_circular_deviation_um']) {
      assert.equal(await page.textContent(`#figures td[data-testid="pair-${k}"]`), um3(pair.pair[k]), k);
    }
  });

  await step('diagnosis table and contribution chart show the joint CW + CCW diagnosis', async () => {
    const pair = await apiGet(server, `/api/v1/measurements/${ids.ccw}/pair`);
    const res = await apiGet(server, `/api/v1/measurements/${ids.ccw}/results`);
    await page.waitForSelector('#analysis:not([hidden])');
    assert.equal(await page.getAttribute('#diagnosis-source', 'data-source'), 'pair');
    assert.match(await page.textContent('#diagnosis-source'), /Joint diagnosis of CW and CCW/);
    const expected = [...pair.joint_diagnosis].sort((a, b) => b.contribution_pct - a.contribution_pct);
    assert.ok(expected.length >= 1, `the fixtures have named effects: ${JSON.stringify(pair.joint_diagnosis)}`);
    await page.waitForSelector('#diagnosis-table-box table[data-source="pair"]');
    const rows = await page.$$eval('#diagnosis-table-box tbody tr', (trs) =>
      trs.map((tr) => ({
        effect: tr.dataset.effect,
        name: tr.querySelector('.effect-name').textContent,
        words: tr.querySelector('.effect-words').textContent,
        value: tr.querySelector('td[data-key="value"]').textContent,
        uncertainty: tr.querySelector('td[data-key="uncertainty"]').textContent,
        pct: tr.querySelector('td[data-key="contribution_pct"]').textContent,
      })),
    );
    assert.deepEqual(rows.map((r) => r.effect), expected.map((d) => d.effect), 'ranked by contribution');
    rows.forEach((r, i) => {
      const d = expected[i];
      assert.equal(r.name, d.effect);
      assert.ok(r.words.length > 0 && r.words !== d.effect, `effect in words: ${r.words}`);
      assert.equal(r.value, valueText(d.value), `${d.effect} value`);
      assert.equal(r.uncertainty, `± ${Array.isArray(d.uncertainty) ? d.uncertainty.map(unc2).join(', ') : unc2(d.uncertainty)}`, `${d.effect} uncertainty`);
      assert.equal(r.pct, fixed1(d.contribution_pct), `${d.effect} contribution`);
    });
    const bars = await page.$$eval('#contribution-chart svg g.bar', (gs) =>
      gs.map((g) => ({ effect: g.dataset.effect, pct: Number(g.dataset.pct), width: Number(g.querySelector('rect').getAttribute('width')), rest: g.classList.contains('rest') })),
    );
    const named = bars.filter((b) => !b.rest);
    assert.deepEqual(named.map((b) => b.effect), expected.map((d) => d.effect));
    named.forEach((b, i) => assert.equal(b.pct, expected[i].contribution_pct));
    // Bar lengths are proportional to the contributions.
    const scale = named[0].width / named[0].pct;
    for (const b of named) assert.ok(Math.abs(b.width - b.pct * scale) < 0.05, `bar ${b.effect}`);
    const total = expected.reduce((s, d) => s + d.contribution_pct, 0);
    const rest = bars.find((b) => b.rest);
    assert.ok(rest && Math.abs(rest.pct - Math.max(0, 100 - total)) < 1e-9, 'unexplained share drawn');
    // Effects that cannot be told apart are listed (muted) when the analysis says so.
    const ni = res.not_identifiable || [];
    assert.equal(await page.isHidden('#not-identifiable'), ni.length === 0);
    for (const n of ni) assert.ok((await page.textContent('#not-identifiable')).includes(n.split(' ')[0]));
  });

  await step('harmonics chart shows the amplitudes of both directions', async () => {
    const drawn = await page.$$eval('#harmonics-chart svg rect[data-order]', (rs) =>
      rs.map((r) => ({ order: Number(r.dataset.order), dir: r.dataset.direction, amp: Number(r.dataset.amplitudeUm), h: Number(r.getAttribute('height')) })),
    );
    let count = 0;
    for (const dir of ['ccw', 'cw']) {
      const res = await apiGet(server, `/api/v1/measurements/${ids[dir]}/results`);
      for (const k of res.harmonics) {
        const bar = drawn.find((b) => b.dir === dir && b.order === k.order);
        assert.ok(bar, `bar for ${dir} order ${k.order}`);
        assert.equal(bar.amp, k.amplitude_um);
        ++count;
      }
      // The fixture's 2nd harmonic (oval, 3.0 / 2.4 µm) shows.
      const second = res.harmonics.find((k) => k.order === 2);
      assert.ok(second && second.amplitude_um > 1.5, `2nd harmonic ${JSON.stringify(second)}`);
    }
    assert.equal(drawn.length, count);
    const tallest = drawn.reduce((a, b) => (b.amp > a.amp ? b : a));
    const ratio = tallest.h / tallest.amp;
    for (const b of drawn) assert.ok(Math.abs(b.h - b.amp * ratio) < 0.05, `height of ${b.dir} ${b.order}`);
  });

  await step('plot.png opens through an authorised fetch', async () => {
    await page.click('#plot-png-button');
    await page.waitForSelector('#png-dialog[open]');
    await page.waitForFunction(() => {
      const img = document.querySelector('#png-image');
      return img.complete && img.naturalWidth > 0;
    });
    const img = await page.$eval('#png-image', (i) => ({ src: i.src, w: i.naturalWidth, h: i.naturalHeight, id: i.dataset.measurementId }));
    assert.match(img.src, /^blob:/);
    assert.equal(Number(img.id), ids.ccw);
    assert.ok(img.w >= 200 && img.h >= 200, `PNG size ${img.w}×${img.h}`);
    await page.screenshot({ path: join(outDir, 'dashboard-png.png') });
    await page.click('#png-close');
    await page.waitForSelector('#png-dialog:not([open])', { state: 'attached' });
  });

  await step('a bad file shows the server validation message', async () => {
    const badPath = join(fixtures, 'dbb_bad_value.txt');
    const bytes = readFileSync(badPath);
    const badLine = badLineOf(bytes.toString('utf8'));
    // What the server says about it (same bytes, same file name)...
    const r = await fetch(`${server.base}/api/v1/measurements`, {
      method: 'POST',
      body: bytes,
      headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': 'text/plain', 'X-Filename': 'dbb_bad_value.txt' },
    });
    assert.equal(r.status, 400);
    assert.match(r.headers.get('content-type') || '', /application\/problem\+json/);
    const problem = await r.json();
    assert.ok(problem.detail, 'problem+json has a detail');
    assert.match(problem.detail, /dr_um/);
    assert.match(problem.detail, new RegExp(`\\b${badLine}\\b`), `detail names line ${badLine}`);
    // ...is what the dashboard shows.
    await page.setInputFiles('#upload-file', badPath);
    await page.click('#upload-button');
    const msg = await page.waitForSelector('#upload-message.error');
    assert.equal(await msg.getAttribute('role'), 'alert');
    assert.equal(await page.textContent('#upload-message .problem-detail'), problem.detail);
    if (problem.title) assert.equal(await page.textContent('#upload-message .problem-title'), problem.title);
    // The plot of the selected test stays.
    assert.equal(await page.$$eval('#polar-plot svg path.trace', (ps) => ps.length), 2);
    const list = await apiGet(server, `/api/v1/measurements?machine_id=${MACHINE}`);
    assert.equal(list.total ?? list.items.length, 2, 'bad file not stored');
  });

  await step('page fits 1280×800, screenshot', async () => {
    const shot = join(outDir, 'dashboard.png');
    await page.screenshot({ path: shot });
    assert.ok(existsSync(shot));
    t.diagnostic(`screenshot: ${shot}`);
    await page.screenshot({ path: join(outDir, 'dashboard-dbb-full.png'), fullPage: true });
    const overflow = await page.evaluate(() => document.documentElement.scrollWidth);
    assert.ok(overflow <= 1280, `no horizontal scrolling (scrollWidth ${overflow})`);
    const box = await page.locator('#polar-plot svg').boundingBox();
    assert.ok(box && box.x + box.width <= 1280 && box.y + box.height <= 800, `plot visible: ${JSON.stringify(box)}`);
    const tbox = await page.locator('#figures table').boundingBox();
    assert.ok(tbox && tbox.x + tbox.width <= 1280, `figures visible: ${JSON.stringify(tbox)}`);
  });


  await step('a wrong token shows the 401 message', async () => {
    const other = await browser.newContext({ viewport: { width: 1280, height: 800 } });
    try {
      const p2 = await other.newPage();
      await p2.goto(`${server.base}/#token=not-the-token`);
      const banner = await p2.waitForSelector('#auth-message.error', { timeout: 15_000 });
      const text = await banner.textContent();
      assert.match(text, /401/);
      assert.match(text, /token/i);
      assert.equal(await p2.$$eval('#machines button', (b) => b.length), 0);
      // Entering the right token in the box recovers.
      await p2.fill('#token-input', server.token);
      await p2.click('#token-save');
      await p2.waitForSelector(`#machines button[data-machine-id="${MACHINE}"]`);
      assert.equal(await p2.isHidden('#auth-message'), true);
      // The landing view with the newest uploads; choosing the machine shows its newest DBB test.
      await p2.waitForSelector('#home-view:not([hidden]) [data-testid="home-uploads"] a');
      await p2.click(`#machines button[data-machine-id="${MACHINE}"]`);
      await p2.waitForSelector(`#measurements a[data-id="${ids.cw}"][aria-current="true"]`);
      await p2.waitForSelector('#polar-plot svg path[data-direction="ccw"]');
      await p2.screenshot({ path: join(outDir, 'dashboard-401-recovered.png') });
    } finally {
      await other.close();
    }
  });
});
