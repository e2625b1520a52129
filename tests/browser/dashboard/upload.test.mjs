// Browser scenario: several files uploaded at once, each with its own
// outcome (a bad file names its line and field; the good ones are stored and linked); files
// dropped on the upload panel; the printable DBB report (print stylesheet: no controls, the test
// conditions); CSV of the list; keyboard focus kept and returned; token messages that never
// contradict each other.
//   node tests/browser/dashboard/upload.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdtempSync, readFileSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { dbbFile, outDir, withDashboard } from '../lib/harness.mjs';

const MACHINE = 'browser-views-vmc';

test('multi-file and dropped uploads with per-file outcomes; report; token messages', { timeout: 60_000 }, async () => {
  await withDashboard('upload', async ({ page, open, server, api }) => {
    // Under the server's data directory, which is removed when the server stops.
    const dir = mkdtempSync(join(server.dataDir, 'multi-'));
    const files = {
      ccw: dbbFile({ machine: MACHINE, direction: 'ccw', timestamp: '2026-04-01T08:00:00Z', extra: ['# temperature_c: 20.4'] }),
      cw: dbbFile({ machine: MACHINE, direction: 'cw', timestamp: '2026-04-01T08:05:00Z', extra: ['# temperature_c: 20.5'] }),
    };
    const bad = files.ccw.replace(/\n10,[^\n]*/, '\n10,abc');
    for (const [name, text] of Object.entries({ ...files, bad })) writeFileSync(join(dir, `${name}.txt`), text);
    await open();
    await page.setInputFiles('#upload-file', ['ccw', 'bad', 'cw'].map((n) => join(dir, `${n}.txt`)));
    await page.click('#upload-button');
    const msg = await page.waitForSelector('#upload-message.warning[data-stored="2"]');
    assert.equal(await msg.getAttribute('data-refused'), '1');
    const outcomes = await page.$$eval('[data-testid="upload-outcome"]', (li) => li.map((x) => ({ outcome: x.dataset.outcome, id: x.dataset.measurementId, text: x.textContent })));
    assert.deepEqual(outcomes.map((o) => o.outcome), ['stored', 'refused', 'stored']);
    assert.match(outcomes[1].text, /bad\.txt/);
    assert.match(outcomes[1].text, /line 21/, outcomes[1].text);
    assert.match(outcomes[1].text, /dr_um/, outcomes[1].text);
    // The last stored file is shown, with its partner (stored in the same batch).
    const cwId = Number(outcomes[2].id);
    await page.waitForSelector(`#detail[data-view="dbb"][data-measurement-id="${cwId}"][data-partner-id="${outcomes[0].id}"]`);

    // Dropped on the panel: the same bytes are "already stored", a new file is stored.
    const dropped = await page.evaluateHandle(([a, b]) => {
      const dt = new DataTransfer();
      dt.items.add(new File([a], 'again_ccw.txt', { type: 'text/plain' }));
      dt.items.add(new File([b], 'new_ccw.txt', { type: 'text/plain' }));
      return dt;
    }, [files.ccw, dbbFile({ machine: MACHINE, test: 'xy-r100', direction: 'ccw', timestamp: '2026-04-02T08:00:00Z' })]);
    await page.dispatchEvent('#upload-panel', 'drop', { dataTransfer: dropped });
    await page.waitForSelector('#upload-message.success[data-stored="2"]');
    const dropOutcomes = await page.$$eval('[data-testid="upload-outcome"]', (li) => li.map((x) => ({ outcome: x.dataset.outcome, id: x.dataset.measurementId })));
    assert.deepEqual(dropOutcomes.map((o) => o.outcome), ['existing', 'stored']);
    // The page shows the last stored file once the machine list is reloaded: wait for it, or
    // it would replace the view chosen next.
    await page.waitForSelector(`#detail[data-measurement-id="${dropOutcomes[1].id}"]`);

    // The printable report of the pair: test conditions, no controls in print.
    await page.evaluate((id) => {
      window.location.hash = `#/measurements/${id}`;
    }, cwId);
    await page.waitForSelector(`#detail[data-measurement-id="${cwId}"] [data-testid="conditions-table"]`);
    // The pair's table is complete once both traces' temperatures are in it (a slow page may
    // still be showing the table of the view before).
    // The table may be redrawn once more after it first shows both: read until it holds still
    // (45 s: a full parallel test run keeps both cores busy).
    const readTemps = () => page.$$eval('[data-testid="conditions-table"] tr[data-key="temperature_c"] td.text', (tds) => tds.map((td) => td.textContent));
    let temps = await readTemps();
    for (const end = Date.now() + 45_000; temps.join() !== '20.4,20.5' && Date.now() < end;) {
      await page.waitForTimeout(50);
      temps = await readTemps();
    }
    assert.deepEqual(temps, ['20.4', '20.5'], 'CCW first, then CW');
    assert.equal(await page.locator('[data-testid="conditions-table"] tr[data-key="feed_mm_min"]').count(), 1);
    await page.emulateMedia({ media: 'print' });
    assert.equal(await page.isHidden('.sidebar'), true, 'print: no sidebar');
    assert.equal(await page.isHidden('#detail-actions'), true, 'print: no buttons');
    assert.equal(await page.isVisible('#polar-plot svg'), true, 'print: the polar plot');
    assert.equal(await page.isVisible('[data-testid="diagnosis-table"], [data-testid="diagnosis-empty"]'), true, 'print: the diagnosis');
    await page.pdf({ path: join(outDir, 'views-report.pdf') }).catch(() => {}); // headless only
    await page.emulateMedia({ media: 'screen' });
    // CSV of the list and of the figures.
    const [listCsv] = await Promise.all([page.waitForEvent('download'), page.click('[data-testid="list-csv"]')]);
    const csv = readFileSync(await listCsv.path(), 'utf8').trim().split(/\r\n/);
    assert.equal(csv.length, 1 + 3, csv.join('\n'));
    assert.match(csv[0], /^id,kind,test_id,direction,measured_at,uploaded_at,filename,key_result,value,unit$/);
    const [figCsv] = await Promise.all([page.waitForEvent('download'), page.click('[data-testid="figures-csv"]')]);
    assert.match(readFileSync(await figCsv.path(), 'utf8'), /circularity_um/);

    // Keyboard focus: back on the button that opened the PNG dialog when it closes; kept on the
    // machine when the machine list is rebuilt (Enter on it reloads its view).
    await page.focus('#plot-png-button');
    await page.keyboard.press('Enter');
    await page.waitForSelector('#png-dialog[open]');
    await page.keyboard.press('Escape');
    await page.waitForSelector('#png-dialog:not([open])', { state: 'attached' });
    // The dialog's close event, which moves the focus, comes as a task after the dialog closed.
    await page.waitForFunction(() => document.activeElement?.id === 'plot-png-button', null, { timeout: 15_000 }).catch(() => {});
    assert.equal(await page.evaluate(() => document.activeElement?.id), 'plot-png-button');
    await page.focus(`#machines [data-machine-id="${MACHINE}"]`);
    await page.keyboard.press('Enter');
    await page.waitForSelector(`#detail[data-view="dbb"]`);
    await page.waitForFunction(() => document.querySelector('#machines [aria-current="true"]') !== null);
    // The list is rebuilt when the machine's view loads: wait until that has settled (a slow,
    // loaded machine may still be rebuilding), then focus must be on the machine.
    await page.waitForLoadState('networkidle');
    await page.waitForFunction((m) => document.activeElement?.dataset?.machineId === m, MACHINE, { timeout: 15_000 }).catch(() => {});
    assert.equal(await page.evaluate(() => document.activeElement?.dataset?.machineId), MACHINE, 'focus kept on the machine');

    // Token messages: a wrong token shows one consistent state, and the right one clears it.
    await page.fill('#token-input', 'not-the-token');
    await page.click('#token-save');
    await page.waitForSelector('#auth-message:not([hidden])');
    await page.waitForFunction(() => document.querySelector('#token-status')?.textContent === 'Token not accepted', null, { timeout: 15_000 }).catch(() => {});
    assert.equal(await page.textContent('#token-status'), 'Token not accepted');
    await page.fill('#token-input', server.token);
    await page.click('#token-save');
    await page.waitForSelector('#auth-message[hidden]', { state: 'attached' });
    await page.waitForFunction(() => document.querySelector('#token-status')?.textContent === 'Access token set', null, { timeout: 15_000 }).catch(() => {});
    assert.equal(await page.textContent('#token-status'), 'Access token set');
    await page.waitForSelector(`#machines [data-machine-id="${MACHINE}"]`);
    assert.equal((await api.get(`/api/v1/measurements?machine_id=${MACHINE}`)).total, 3);
  });
});
