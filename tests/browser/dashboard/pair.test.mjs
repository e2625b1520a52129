// Browser scenario: an older CCW test is drawn and tabled with its own
// partner — the one the server's /pair uses — not with the newest CW file of the same test_id;
// the DBB view says which files it shows (data-measurement-id, data-partner-id, a note naming
// the partner's file); another test overlaid at the same scale (before / after); a reload on the
// deep link #/measurements/{id} returns to the same view.
//   node tests/browser/dashboard/pair.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { dbbFile, outDir, withDashboard } from '../lib/harness.mjs';

test('an older CCW test shows its own partner; reload keeps the view', { timeout: 60_000 }, async () => {
  await withDashboard('pair', async ({ api, page, open }) => {
    // Two sessions of the same test, five months apart: #a CCW + CW, then #b CCW + CW.
    const ids = {};
    ids.oldCcw = (await api.upload(dbbFile({ direction: 'ccw', timestamp: '2026-06-01T08:00:00Z', shape: 0 }), 'june_ccw.txt')).id;
    ids.oldCw = (await api.upload(dbbFile({ direction: 'cw', timestamp: '2026-06-01T08:05:00Z', shape: 0 }), 'june_cw.txt')).id;
    ids.newCcw = (await api.upload(dbbFile({ direction: 'ccw', timestamp: '2026-11-01T08:00:00Z', shape: 1 }), 'november_ccw.txt')).id;
    ids.newCw = (await api.upload(dbbFile({ direction: 'cw', timestamp: '2026-11-01T08:05:00Z', shape: 1 }), 'november_cw.txt')).id;
    const pair = await api.get(`/api/v1/measurements/${ids.oldCcw}/pair`);
    assert.equal(pair.partner_id, ids.oldCw, 'the server pairs the June CCW with the June CW');

    await open(`#/measurements/${ids.oldCcw}`);
    const view = page.locator('#detail[data-view="dbb"]');
    await page.waitForSelector(`#detail[data-view="dbb"][data-measurement-id="${ids.oldCcw}"][data-partner-id="${ids.oldCw}"]`);
    assert.equal(await view.getAttribute('data-partner-id'), String(pair.partner_id));
    // The plot, the figures and the diagnosis are of exactly this pair.
    await page.waitForSelector('#polar-plot svg path[data-direction="cw"]');
    const columns = await page.$$eval('[data-testid="figures-table"] td[data-key="circularity_um"]', (tds) => tds.map((td) => Number(td.dataset.id)).sort((a, b) => a - b));
    assert.deepEqual(columns, [ids.oldCcw, ids.oldCw].sort((a, b) => a - b), 'figures of the June pair');
    const note = await page.textContent('[data-testid="pair-note"]');
    assert.match(note, new RegExp(`#${ids.oldCw} \\(june_cw\\.txt\\)`), `the note names the partner's file: ${note}`);
    assert.match(await page.textContent('[data-testid="diagnosis-source"]'), new RegExp(`#${ids.oldCw}`));
    const hysteresis = await page.textContent('[data-testid="pair-circular_hysteresis_um"]');
    assert.equal(Number(hysteresis.replace('−', '-')).toFixed(3), pair.pair.circular_hysteresis_um.toFixed(3));
    // H about each trace's own centre beside the ISO figure about the common centre.
    const own = await page.textContent('[data-testid="pair-circular_hysteresis_own_centres_um"]');
    assert.equal(Number(own.replace('−', '-')).toFixed(3), pair.pair.circular_hysteresis_own_centres_um.toFixed(3));
    assert.match(await page.textContent('tr[data-key="pair.circular_hysteresis_um"] th'), /common centre/);

    // Before / after: the November CCW overlaid on the June pair, at one scale for all three.
    await page.fill('[data-testid="compare-id"]', `#${ids.newCcw}`);
    await page.click('[data-testid="compare-add"]');
    await page.waitForSelector(`#polar-plot svg path[data-role="compare"][data-measurement-id="${ids.newCcw}"]`);
    assert.equal(await page.locator('#polar-plot svg path.trace').count(), 3);
    const traces = await Promise.all([ids.oldCcw, ids.oldCw, ids.newCcw].map((id) => api.get(`/api/v1/measurements/${id}/trace`)));
    const maxAbs = Math.max(...traces.flatMap((tr) => tr.radial_error_um.map(Math.abs)));
    const umPerDiv = Number(await page.getAttribute('#polar-plot svg', 'data-um-per-div'));
    assert.ok(maxAbs <= 3 * umPerDiv, `one scale holds all three traces (${maxAbs} µm, ${umPerDiv} µm/div)`);
    assert.match(await page.textContent('[data-testid="compare-note"]'), new RegExp(`#${ids.newCcw} \\(november_ccw\\.txt\\)`));
    // The plot as shown, overlay included, saved as a PNG with the key figures under it.
    const [png] = await Promise.all([page.waitForEvent('download'), page.click('[data-testid="plot-save-png"]')]);
    const bytes = readFileSync(await png.path());
    await png.saveAs(join(outDir, 'views-plot-as-shown.png'));
    assert.equal(bytes.subarray(1, 4).toString(), 'PNG');
    assert.equal(bytes.readUInt32BE(16), 900, 'PNG width');
    const lines = Number(await page.getAttribute('[data-testid="plot-save-png"]', 'data-lines'));
    assert.equal(bytes.readUInt32BE(20), 900 + 20 + lines * 26, 'PNG height: the plot and the key figures');
    assert.ok(lines >= 5, `heading, two directions, H, G(b), overlay: ${lines} lines`);
    await page.click('[data-testid="compare-clear"]');
    await page.waitForSelector('#polar-plot svg path[data-role="compare"]', { state: 'detached' });

    // The list is newest first: the November files on top.
    const listed = await page.$$eval('#measurements [data-testid="measurement-item"]', (as) => as.map((a) => Number(a.dataset.id)));
    assert.deepEqual(listed, [ids.newCw, ids.newCcw, ids.oldCw, ids.oldCcw]);
    assert.equal(await page.getAttribute(`#measurements [data-id="${ids.oldCcw}"]`, 'aria-current'), 'true');

    // The partner link goes to the partner's own view; its partner is the June CCW again
    // (measured nearest in time, though the November CCW was stored as near to it).
    const back = (await api.get(`/api/v1/measurements/${ids.oldCw}/pair`)).partner_id;
    assert.equal(back, ids.oldCcw);
    await page.click('[data-testid="partner-link"]');
    await page.waitForSelector(`#detail[data-measurement-id="${ids.oldCw}"][data-partner-id="${back}"]`);
    assert.match(page.url(), new RegExp(`#/measurements/${ids.oldCw}$`));

    // Reload on the deep link: the same view comes back.
    await page.reload();
    await page.waitForSelector(`#detail[data-view="dbb"][data-measurement-id="${ids.oldCw}"][data-partner-id="${back}"]`);
    await page.waitForSelector(`#machines [data-machine-id="browser-views-vmc"][aria-current="true"]`);
    await page.screenshot({ path: join(outDir, 'views-pair.png') });
  });
});

test('demo data: every DBB test is drawn with the partner /pair gives it', { timeout: 60_000 }, async () => {
  await withDashboard(
    'pair-demo',
    async ({ api, page, open }) => {
      const list = await api.get('/api/v1/measurements?machine_id=demo-vmc&kind=dbb&limit=100');
      assert.ok(list.items.length >= 6, `demo DBB tests: ${list.items.length}`);
      await open();
      for (const m of list.items.slice(0, 6)) {
        const pair = await api.get(`/api/v1/measurements/${m.id}/pair`).catch(() => null);
        await page.evaluate((id) => {
          window.location.hash = `#/measurements/${id}`;
        }, m.id);
        await page.waitForSelector(`#detail[data-view="dbb"][data-measurement-id="${m.id}"]`);
        assert.equal(await page.getAttribute('#detail', 'data-partner-id'), pair ? String(pair.partner_id) : null, `#${m.id}`);
        if (pair) assert.match(await page.textContent('[data-testid="diagnosis-source"]'), new RegExp(`#${pair.partner_id}\\b`));
      }
    },
    { serverArgs: ['--demo-data'] },
  );
});
