// Browser scenario: 210 uploads on one machine. The list is newest
// first and paged on the server; the newest is one click away (the first row) and found by the
// free-text filter; kind, test and date filters, a key result on every row, the next page and
// back; a file uploaded through the form with an old measurement time is reached from its
// "stored as #N" link; a reload keeps the machine view; at 400 px nothing overflows sideways.
//   node tests/browser/dashboard/list.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { writeFileSync, mkdtempSync } from 'node:fs';
import { join } from 'node:path';
import { assertNoHorizontalOverflow, dbbFile, outDir, withDashboard } from '../lib/harness.mjs';

const MACHINE = 'browser-views-vmc';

test('210 uploads: newest first, paged, filtered, reachable in one click', { timeout: 110_000 }, async () => {
  await withDashboard('list', async ({ api, page, open, server }) => {
    // 105 CCW + CW pairs, one a day from 2026-01-01, uploaded oldest first.
    const ids = [];
    const t0 = Date.UTC(2026, 0, 1, 8);
    for (let k = 0; k < 105; ++k) {
      for (const [j, direction] of ['ccw', 'cw'].entries()) {
        const timestamp = new Date(t0 + k * 86_400_000 + j * 300_000).toISOString().replace('.000Z', 'Z');
        const test = k % 3 === 0 ? 'xy-r100' : 'xy-r150';
        const text = dbbFile({ machine: MACHINE, test, direction, timestamp, shape: (k % 7) / 10 });
        ids.push({ id: (await api.upload(text, `run${String(k).padStart(3, '0')}_${direction}.txt`)).id, timestamp, test, direction });
      }
    }
    const newest = ids[ids.length - 1];
    const apiFirst = await api.get(`/api/v1/measurements?machine_id=${MACHINE}&order=newest&limit=50`);
    assert.equal(apiFirst.total, 210);
    assert.equal(apiFirst.items[0].id, newest.id);
    assert.equal(typeof apiFirst.items[0].key_result.value, 'number');

    await open(`#/machines/${MACHINE}`);
    await page.waitForSelector(`#measurements [data-testid="measurement-item"][data-id="${newest.id}"]`);
    const rows = await page.$$eval('#measurements [data-testid="measurement-item"]', (as) => as.map((a) => Number(a.dataset.id)));
    assert.equal(rows.length, 50, 'one page of 50');
    assert.deepEqual(rows, apiFirst.items.map((m) => m.id), 'the page is the server\'s newest-first page');
    assert.equal(await page.textContent('[data-testid="list-range"]'), '1–50 of 210');
    assert.equal(await page.textContent('[data-testid="measurements-count"]'), '210');
    // Every row has its key result (the circularity of a DBB test), as the API gives it.
    const key = await page.textContent(`#measurements [data-id="${newest.id}"] [data-testid="key-result"]`);
    assert.equal(key, `circularity ${apiFirst.items[0].key_result.value.toFixed(3)} µm`);
    // The newest in one click: the first row.
    await page.click(`#measurements [data-id="${newest.id}"]`);
    await page.waitForSelector(`#detail[data-view="dbb"][data-measurement-id="${newest.id}"]`);
    assert.match(page.url(), new RegExp(`#/measurements/${newest.id}$`));

    // Paging: the next page starts where the first ended; back again.
    await page.click('[data-testid="list-next"]');
    await page.waitForSelector('[data-testid="list-range"]:has-text("51–100 of 210")');
    const second = await page.$$eval('#measurements [data-testid="measurement-item"]', (as) => as.map((a) => Number(a.dataset.id)));
    const apiSecond = await api.get(`/api/v1/measurements?machine_id=${MACHINE}&order=newest&limit=50&offset=50`);
    assert.deepEqual(second, apiSecond.items.map((m) => m.id));
    await page.click('[data-testid="list-prev"]');
    await page.waitForSelector('[data-testid="list-range"]:has-text("1–50 of 210")');

    // Filters: free text finds the newest by its file name or id; kind, test and dates narrow.
    await page.fill('[data-testid="filter-q"]', 'run104_cw');
    await page.waitForSelector('[data-testid="list-range"]:has-text("1–1 of 1")');
    assert.equal(await page.getAttribute('#measurements [data-testid="measurement-item"]', 'data-id'), String(newest.id));
    await page.fill('[data-testid="filter-q"]', `#${ids[3].id}`);
    await page.waitForSelector(`#measurements li:only-child [data-testid="measurement-item"][data-id="${ids[3].id}"]`);
    assert.equal(await page.textContent('[data-testid="list-range"]'), '1–1 of 1');
    await page.fill('[data-testid="filter-q"]', '');
    await page.fill('[data-testid="filter-test"]', 'xy-r100');
    await page.waitForSelector('[data-testid="list-range"]:has-text("of 70")');
    await page.fill('[data-testid="filter-from"]', '2026-01-10');
    await page.fill('[data-testid="filter-to"]', '2026-01-12');
    // Days 10 to 12 (k = 9, 10, 11), test xy-r100 only on k = 9: its two files.
    await page.waitForSelector('[data-testid="list-range"]:has-text("1–2 of 2")');
    const filtered = await page.$$eval('#measurements [data-testid="measurement-item"]', (as) => as.map((a) => a.dataset.testId));
    assert.deepEqual(filtered, ['xy-r100', 'xy-r100']);
    await page.selectOption('[data-testid="filter-kind"]', 'tracker');
    await page.waitForSelector('#measurements li.empty:has-text("No measurement matches")');
    await page.click('#list-filters button[type="reset"]');
    await page.waitForSelector('[data-testid="list-range"]:has-text("1–50 of 210")');

    // An upload through the form with an old measurement time: "stored as #N" leads to it.
    // Under the server's data directory, which is removed when the server stops.
    const dir = mkdtempSync(join(server.dataDir, 'upload-'));
    const oldFile = join(dir, 'late_upload_ccw.txt');
    writeFileSync(oldFile, dbbFile({ machine: MACHINE, test: 'xy-r150', direction: 'ccw', timestamp: '2025-12-01T08:00:00Z', shape: 0.05 }));
    await page.setInputFiles('#upload-file', oldFile);
    await page.click('#upload-button');
    const msg = await page.waitForSelector('#upload-message.success');
    const stored = Number(await msg.getAttribute('data-measurement-id'));
    await page.waitForSelector(`#detail[data-measurement-id="${stored}"]`);
    assert.match(await page.textContent('[data-testid="pair-note"]'), /#\d+/);
    // Newest upload first puts it on top.
    await page.selectOption('[data-testid="filter-order"]', 'uploaded');
    await page.waitForSelector(`#measurements li:first-child [data-id="${stored}"]`);

    // Reload on the machine's address keeps the machine view.
    await page.evaluate((m) => {
      window.location.hash = `#/machines/${m}`;
    }, MACHINE);
    await page.reload();
    await page.waitForSelector(`#machines [data-machine-id="${MACHINE}"][aria-current="true"]`);
    await page.waitForSelector('[data-testid="list-range"]:has-text("1–50 of 211")');

    // 400 px wide: the header, the list and the DBB view fit; nothing scrolls sideways.
    await page.setViewportSize({ width: 400, height: 800 });
    await page.click(`#measurements [data-id="${newest.id}"]`);
    await page.waitForSelector(`#detail[data-measurement-id="${newest.id}"] #polar-plot svg`);
    await assertNoHorizontalOverflow(page, '400 px, DBB view');
    await page.click('[data-testid="menu-button"]'); // the token form folded behind the top bar's button
    const tokenBox = await page.locator('#token-save').boundingBox();
    assert.ok(tokenBox && tokenBox.x >= 0 && tokenBox.x + tokenBox.width <= 400, `token button on screen: ${JSON.stringify(tokenBox)}`);
    await page.screenshot({ path: join(outDir, 'views-list-400px.png'), fullPage: false });
  });
});
