// Browser scenarios of the page at 1366 and 400 px wide (issue 39, "The page"), each on its own
// server:
// - a positioning test's view offers its compensation table for LinuxCNC, SINUMERIK and CSV,
//   saved under the server's file name (Content-Disposition: attachment, a safe name with the
//   format's extension); its figures read in words with units (ISO 230-2 compliant: yes, VDI 3441
//   P) and its conditions (air, material, corrections) are a block of their own;
// - straightness and flatness views name their axis, error direction, sensor and reference;
// - at 400 px the top bar is compact (≤ 64 px, the token form behind its button), the DBB plot
//   starts near the top, the landing view's lists are not far down, wide tables (tokens, audit
//   log) scroll in their own box to their last column, the stream chart's text keeps its size;
// - a token's secret has a Copy button (clipboard, else the secret selected);
// - counts in the right number ("1 gap");
// - no GET …/pair or …/reversal for a test without a partner: no failed request, no console error;
// - the saved PNG of a DBB plot keeps its angle labels inside the picture, in the server's
//   colours, and the server's PNG is asked at the page's scale.
//   node tests/browser/dashboard/narrow_page.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { dbbFile, outDir, repo, withDashboard } from '../lib/harness.mjs';

const example = (name) => readFileSync(join(repo, 'data/examples', name), 'utf8');
const WIDTHS = [1366, 400];
const go = (page, hash) =>
  page.evaluate((h) => {
    window.location.hash = h;
  }, hash);

// Every answer of 400 or more the page gets, but GET …/tolerances of a machine without a table
// (tolerances.js, outside this scenario).
function watchFailures(page) {
  const failed = [];
  const asked = [];
  page.on('request', (req) => asked.push(new URL(req.url()).pathname + new URL(req.url()).search));
  page.on('response', (r) => {
    if (r.status() >= 400 && !/\/tolerances$/.test(new URL(r.url()).pathname)) failed.push(`${r.status()} ${r.url()}`);
  });
  page.on('requestfailed', (req) => failed.push(`failed ${req.url()}`));
  return { failed, asked };
}

async function headerHeight(page) {
  return page.evaluate(() => document.querySelector('.topbar').getBoundingClientRect().height);
}

test('positioning: compensation downloads, readable labels, conditions apart', { timeout: 170_000 }, async () => {
  await withDashboard('narrow-positioning', async ({ server, api, page, open }) => {
    const { failed } = watchFailures(page);
    const pos = (await api.upload(example('positioning_x.txt'), 'positioning_x.txt')).id;
    // The route itself: an attachment with a safe name and the format's extension.
    for (const [format, ext] of [['linuxcnc', 'comp'], ['sinumerik', 'spf'], ['csv', 'csv']]) {
      const r = await fetch(`${server.base}/api/v1/measurements/${pos}/compensation?format=${format}`, { headers: { Authorization: `Bearer ${server.token}` } });
      assert.equal(r.status, 200);
      assert.equal(r.headers.get('content-disposition'), `attachment; filename="kinemetric-${pos}-compensation.${ext}"`);
    }
    const bad = await fetch(`${server.base}/api/v1/measurements/${pos}/compensation?format=fanuc`, { headers: { Authorization: `Bearer ${server.token}` } });
    assert.equal(bad.status, 400);
    assert.equal(bad.headers.get('content-disposition'), null, 'no file offered for a refused format');
    for (const width of WIDTHS) {
      await page.setViewportSize({ width, height: 900 });
      await open(`#/measurements/${pos}`);
      await page.waitForSelector(`#detail[data-measurement-id="${pos}"] [data-testid="compensation-downloads"]`);
      for (const [format, ext] of [['linuxcnc', 'comp'], ['sinumerik', 'spf'], ['csv', 'csv']]) {
        const button = page.locator(`[data-testid="compensation-${format}"]`);
        await button.scrollIntoViewIfNeeded();
        const [download] = await Promise.all([page.waitForEvent('download'), button.click()]);
        assert.equal(download.suggestedFilename(), `kinemetric-${pos}-compensation.${ext}`);
        const saved = readFileSync(await download.path(), 'utf8');
        const direct = await (await fetch(`${server.base}/api/v1/measurements/${pos}/compensation?format=${format}`, { headers: { Authorization: `Bearer ${server.token}` } })).text();
        assert.equal(saved, direct, `${format}: the server's table`);
      }
      // Labels in words, booleans as yes / no, no raw keys.
      const figures = await page.textContent('[data-testid="figures-table"]');
      assert.doesNotMatch(figures, /Iso230|Vdi3441|\btrue\b|\bfalse\b|Air:|Material:/, figures);
      const row = async (key) => (await page.textContent(`[data-testid="figures-table"] tr[data-key="${key}"]`)).replace(/\s+/g, ' ').trim();
      assert.match(await row('iso230_2_compliant'), /^ISO 230-2 compliant\s*yes/);
      assert.match(await row('vdi3441.P_um'), /^VDI 3441 P \(position uncertainty\)\s*µm\s*\d/);
      assert.match(await row('accuracy_um'), /^Accuracy A\s*µm\s*\d/);
      // The conditions in their own block, with units.
      const cond = (key) => page.$eval(`[data-testid="positioning-conditions"] tr[data-key="${key}"]`, (tr) => [...tr.children].map((c) => c.textContent).join(' '));
      assert.equal(await cond('air_pressure_pa'), 'Air pressure 1008.5 hPa');
      assert.equal(await cond('expansion_ppm_per_k'), 'Expansion coefficient α 11.50 µm/(m·K)');
      assert.equal(await cond('material_temperature_c'), 'Material temperature 22.10 °C');
      assert.equal(await page.$$eval('[data-testid="figures-table"] tr[data-key^="air."], [data-testid="figures-table"] tr[data-key^="material."]', (trs) => trs.length), 0, 'no conditions among the figures');
      assert.equal(await page.textContent('[data-testid="positioning-corrections"] tr[data-key="air"] td[data-key="applied"]'), 'yes');
      assert.match(await page.textContent('#plot-note'), /5 runs, 11 targets/);
      await page.screenshot({ path: join(outDir, `narrow-positioning-${width}.png`) });
    }
    assert.deepEqual(failed, []);
  });
});

test('straightness and flatness name their set-up; no pair or reversal asked without a partner', { timeout: 170_000 }, async () => {
  await withDashboard('narrow-setup', async ({ api, page, open }) => {
    const { failed, asked } = watchFailures(page);
    const straight = (await api.upload(example('straightness_reversal_a.txt'), 'straightness_a.txt')).id;
    const flat = (await api.upload(example('flatness_table.txt'), 'flatness_table.txt')).id;
    const solo = (await api.upload(dbbFile({ machine: 'vmc-3axis', test: 'solo', direction: 'ccw', timestamp: '2026-04-01T08:00:00Z' }), 'solo.txt')).id;
    const ccw = (await api.upload(example('dbb_xy-r150_ccw.txt'), 'ccw.txt')).id;
    const cw = (await api.upload(example('dbb_xy-r150_cw.txt'), 'cw.txt')).id;
    // The measurement names its partner, or null.
    assert.equal((await api.get(`/api/v1/measurements/${solo}`)).partner_id, null);
    assert.equal((await api.get(`/api/v1/measurements/${straight}`)).partner_id, null);
    assert.equal((await api.get(`/api/v1/measurements/${ccw}`)).partner_id, cw);
    for (const width of WIDTHS) {
      await page.setViewportSize({ width, height: 900 });
      await open(`#/measurements/${straight}`);
      await page.waitForSelector(`#detail[data-measurement-id="${straight}"] [data-testid="form-setup"]`);
      await page.waitForSelector('[data-testid="reversal-missing"]');
      const setup = async () => Object.fromEntries(await page.$$eval('[data-testid="form-setup"] tr', (trs) => trs.map((tr) => [tr.dataset.key, tr.querySelector('td').textContent])));
      const s = await setup();
      assert.equal(s.axis, 'X');
      assert.equal(s.error_direction, 'Y');
      assert.equal(s.sensor, 'indicator');
      assert.equal(s.reference, 'straightedge');
      assert.equal(s.figures_reference, 'least squares line');
      await go(page, `#/measurements/${flat}`);
      await page.waitForSelector(`#detail[data-measurement-id="${flat}"] [data-testid="form-setup"]`);
      const f = await setup();
      assert.equal(f.axis, 'XY');
      assert.equal(f.error_direction, 'Z (height)');
      assert.equal(f.sensor, 'not stated in the file');
      assert.equal(f.reference, 'the table');
      assert.equal(f.figures_reference, 'least squares plane');
      await go(page, `#/measurements/${solo}`);
      await page.waitForSelector(`#detail[data-measurement-id="${solo}"] [data-testid="pair-note"]:not([hidden])`);
      await go(page, `#/measurements/${ccw}`);
      await page.waitForSelector(`#detail[data-measurement-id="${ccw}"][data-partner-id="${cw}"]`);
    }
    assert.ok(!asked.some((p) => p.includes(`/measurements/${solo}/pair`)), 'no /pair for a test without a partner');
    assert.ok(!asked.some((p) => p.includes(`/measurements/${straight}/reversal`)), 'no /reversal without the other set-up');
    assert.ok(asked.some((p) => p.includes(`/measurements/${ccw}/pair`)), '/pair asked for a paired test');
    assert.deepEqual(failed, [], 'no failed request');
  });
});

test('400 px: compact header, the plot first, the lists near, wide tables and charts usable', { timeout: 170_000 }, async () => {
  await withDashboard('narrow-layout', async ({ server, api, page, open }) => {
    const { failed } = watchFailures(page);
    const ccw = (await api.upload(example('dbb_xy-r150_ccw.txt'), 'ccw.txt')).id;
    await api.upload(example('dbb_xy-r150_cw.txt'), 'cw.txt');
    // A stream with one gap.
    const stream = await api.post('/api/v1/streams', JSON.stringify({ machine_id: 'vmc-3axis', name: 'narrow', channels: [{ channel: 1 }] }));
    const lines = [0, 1000, 3000].map((b) => JSON.stringify({ channel: 1, first_counter: b, t0_us: 1763700000000000 + b * 100, dt_us: 100, values_um: Array.from({ length: 1000 }, (_, k) => 0.2 * Math.sin((b + k) / 300)) }));
    await api.post(`/api/v1/streams/${stream.id}/frames`, `${lines.join('\n')}\n`, 'application/x-ndjson');
    // At 1366 px the token form stays in the bar, no menu button.
    await page.setViewportSize({ width: 1366, height: 900 });
    await open('#/');
    assert.equal(await page.isVisible('#token-save'), true);
    assert.equal(await page.isVisible('[data-testid="menu-button"]'), false);

    await page.setViewportSize({ width: 400, height: 800 });
    await open('#/');
    await page.waitForSelector('#machines li');
    const at = (sel) => page.$eval(sel, (e) => Math.round(e.getBoundingClientRect().top + window.scrollY));
    const home = { header: await headerHeight(page), upload: await at('#upload-panel'), machines: await at('#machines'), measurements: await at('#measurements'), homeView: await at('#home-view') };
    console.log(`400 px landing view: ${JSON.stringify(home)}`);
    assert.ok(home.header <= 64, `header ${home.header} px`);
    assert.ok(home.upload <= 200 && home.machines <= 600 && home.measurements <= 1200, `lists near the top: ${JSON.stringify(home)}`);
    // The token form behind its button.
    assert.equal(await page.isVisible('#token-save'), false);
    await page.click('[data-testid="menu-button"]');
    const tokenBox = await page.locator('#token-save').boundingBox();
    assert.ok(tokenBox && tokenBox.x >= 0 && tokenBox.x + tokenBox.width <= 400, `token button on screen: ${JSON.stringify(tokenBox)}`);
    assert.equal(await page.getAttribute('[data-testid="menu-button"]', 'aria-expanded'), 'true');
    await page.click('[data-testid="menu-button"]');
    await page.screenshot({ path: join(outDir, 'narrow-home-400.png') });

    // The DBB plot near the top.
    await go(page, `#/measurements/${ccw}`);
    await page.waitForSelector(`#detail[data-measurement-id="${ccw}"] #polar-plot svg`);
    const dbb = { header: await headerHeight(page), plot: await at('#polar-plot'), figures: await at('#figures') };
    console.log(`400 px DBB view: ${JSON.stringify(dbb)}`);
    assert.ok(dbb.header <= 64, `header ${dbb.header} px`);
    assert.ok(dbb.plot <= 200, `plot top ${dbb.plot} px`);
    assert.ok(await page.isVisible('#plot-save-png'), 'the buttons are still offered');
    await page.screenshot({ path: join(outDir, 'narrow-dbb-400.png') });

    // Tokens and the audit log: their last column reachable inside their box.
    await go(page, '#/tokens');
    await page.fill('[data-testid="token-create-name"]', 'wall screen');
    await page.click('[data-testid="token-create"]');
    await page.waitForSelector('[data-testid="token-secret"]');
    await page.waitForSelector('[data-testid="tokens-table"] tr[data-token-id] [data-testid="token-revoke"]');
    await page.waitForSelector('[data-testid="audit-log"] tr[data-log-id]');
    assert.ok((await headerHeight(page)) <= 64);
    for (const [table, last] of [['tokens-table', '[data-testid="token-revoke"]'], ['audit-log', 'td.num']]) {
      const r = await page.$eval(`[data-testid="${table}"]`, (t, lastSel) => {
        const box = t.closest('.table-scroll');
        box.scrollLeft = box.scrollWidth;
        const cell = t.querySelector(`tbody tr ${lastSel}`);
        const b = box.getBoundingClientRect();
        const c = cell.getBoundingClientRect();
        return { scrolls: getComputedStyle(box).overflowX, boxRight: b.right, cellLeft: c.left, cellRight: c.right, width: document.documentElement.clientWidth };
      }, last);
      assert.equal(r.scrolls, 'auto', `${table} scrolls in its box`);
      assert.ok(r.cellLeft >= 0 && r.cellRight <= r.boxRight + 1 && r.boxRight <= r.width, `${table}: last column reachable ${JSON.stringify(r)}`);
    }
    await page.screenshot({ path: join(outDir, 'narrow-tokens-400.png') });

    // The stream chart's text in CSS pixels; one gap said in the singular.
    await page.click('[data-testid="streams-refresh"]');
    await page.locator(`[data-testid="streams-table"] tr[data-stream="${stream.id}"] button.link`).click();
    await page.waitForSelector(`[data-testid="stream-svg"][data-stream="${stream.id}"]`);
    const tick = await page.$eval('[data-testid="stream-svg"] text.tick', (t) => t.getBoundingClientRect().height);
    assert.ok(tick >= 11, `tick labels ${tick} px tall`);
    assert.match(await page.textContent('[data-testid="stream-summary"]'), /3,000 samples, 1 gap$/);
    await page.screenshot({ path: join(outDir, 'narrow-stream-400.png') });
    assert.deepEqual(failed, []);
    void server;
  });
});

test('token copy button; the saved DBB PNG keeps its labels, in the server’s colours and scale', { timeout: 170_000 }, async () => {
  await withDashboard('narrow-png', async ({ api, page, open }) => {
    const { failed, asked } = watchFailures(page);
    const ccw = (await api.upload(example('dbb_xy-r150_ccw.txt'), 'ccw.txt')).id;
    await api.upload(example('dbb_xy-r150_cw.txt'), 'cw.txt');
    await page.context().grantPermissions(['clipboard-read', 'clipboard-write']);
    for (const width of WIDTHS) {
      await page.setViewportSize({ width, height: 900 });
      await open('#/tokens');
      // The secret of this token, not the one the previous width's token left on the page.
      const before = await page.$eval('[data-testid="token-secret"]', (n) => n.textContent).catch(() => null);
      await page.fill('[data-testid="token-create-name"]', `tablet ${width}`);
      await page.click('[data-testid="token-create"]');
      await page.waitForFunction((old) => {
        const n = document.querySelector('[data-testid="token-secret"]');
        return n && n.textContent && n.textContent !== old;
      }, before);
      const secret = await page.textContent('[data-testid="token-secret"]');
      // What the page writes to the clipboard, recorded in the page: the system clipboard is
      // shared with every other browser test running at the same time.
      await page.evaluate(() => {
        window.copiedTexts = [];
        navigator.clipboard.writeText = (text) => { window.copiedTexts.push(text); return Promise.resolve(); };
      });
      await page.click('[data-testid="token-copy"]');
      await page.waitForSelector('[data-testid="token-copy-status"][data-copied="clipboard"]');
      assert.deepEqual(await page.evaluate(() => window.copiedTexts), [secret]);
      // Without a clipboard: the secret selected.
      await page.evaluate(() => Object.defineProperty(navigator, 'clipboard', { value: undefined, configurable: true }));
      await page.click('[data-testid="token-copy"]');
      await page.waitForSelector('[data-testid="token-copy-status"][data-copied="selected"]');
      assert.equal(await page.evaluate(() => String(window.getSelection())), secret);
      await page.evaluate(() => delete navigator.clipboard);

      await open(`#/measurements/${ccw}`);
      await page.waitForSelector(`#detail[data-measurement-id="${ccw}"][data-partner-id] #polar-plot svg [data-testid="trace-cw"]`);
      const colours = await page.$$eval('#polar-plot svg path.trace', (ps) => ps.map((p) => [p.dataset.direction, p.getAttribute('stroke')]));
      assert.deepEqual(Object.fromEntries(colours), { ccw: '#143cc8', cw: '#d21e1e' }, 'render/dbb_plot.cpp colours');
      const umPerDiv = await page.getAttribute('#polar-plot svg', 'data-um-per-div');
      // The server's PNG at the page's scale.
      await page.click('#plot-png-button');
      await page.waitForSelector('[data-testid="png-image"][src^="blob:"]');
      assert.ok(asked.some((p) => p === `/api/v1/measurements/${ccw}/plot.png?um_per_div=${umPerDiv}&divisions=3`), `plot.png at ${umPerDiv} µm/div: ${asked.filter((p) => p.includes('plot.png'))}`);
      await page.click('#png-close');
      // The page's PNG: white round the drawing (no label cut at an edge).
      await page.locator('#plot-save-png').scrollIntoViewIfNeeded();
      const [png] = await Promise.all([page.waitForEvent('download'), page.click('#plot-save-png')]);
      const data = readFileSync(await png.path()).toString('base64');
      const edges = await page.evaluate(async (b64) => {
        const img = new Image();
        img.src = `data:image/png;base64,${b64}`;
        await img.decode();
        const c = document.createElement('canvas');
        c.width = img.width;
        c.height = img.height;
        const g = c.getContext('2d');
        g.drawImage(img, 0, 0);
        const inked = (x0, y0, w, h) => {
          const d = g.getImageData(x0, y0, w, h).data;
          for (let i = 0; i < d.length; i += 4) if (d[i] < 200 || d[i + 1] < 200 || d[i + 2] < 200) return true;
          return false;
        };
        // The plot is the top 900 × 900 px: its outer 8 px on the left and right are blank, and
        // the labels 180° and 0° are drawn inside.
        return { width: img.width, left: inked(0, 0, 8, 900), right: inked(img.width - 8, 0, 8, 900), nearLeft: inked(8, 420, 80, 60), nearRight: inked(img.width - 88, 420, 80, 60) };
      }, data);
      assert.deepEqual(edges, { width: 900, left: false, right: false, nearLeft: true, nearRight: true }, 'the angle labels inside the picture');
    }
    assert.deepEqual(failed, []);
  });
});
