// Browser scenarios of what the dashboard offers and says, each on its own server:
// - discovery: the start form chooses the tests of one plane by default (the plane of the newest
//   test), refuses a choice in two planes before sending anything, and the job it sends is of
//   one plane; at the end of the discovery a viewer is not offered "New discovery";
// - the overlay box of a DBB test shows the server's message (and the page's own) in words,
//   never "[object Object]", for a problem+json answer and for an {"error": {…}} answer;
// - the audit PDF button only for a machine that has an audit;
// - every time on the page in UTC and saying so ("2026-04-02 08:05 UTC"), whatever the
//   browser's zone.
//   node tests/browser/dashboard/page_views.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { dbbFile, makeToken, outDir, withDashboard } from '../lib/harness.mjs';

const MACHINE = 'views-vmc';

const go = (page, hash) =>
  page.evaluate((h) => {
    window.location.hash = h;
  }, hash);

// Two set-ups in the XY plane measured first, two in YZ measured the next day.
async function uploadTwoPlanes(api) {
  const yz = ['# plane: YZ'];
  return {
    xyCcw: (await api.upload(dbbFile({ machine: MACHINE, test: 'xy-r150', direction: 'ccw', timestamp: '2026-04-01T08:00:00Z', shape: 0 }), 'xy_ccw.txt')).id,
    xyCw: (await api.upload(dbbFile({ machine: MACHINE, test: 'xy-r150', direction: 'cw', timestamp: '2026-04-01T08:05:00Z', shape: 1 }), 'xy_cw.txt')).id,
    yzCcw: (await api.upload(dbbFile({ machine: MACHINE, test: 'yz-r150', direction: 'ccw', timestamp: '2026-04-02T08:00:00Z', shape: 2, extra: yz }), 'yz_ccw.txt')).id,
    yzCw: (await api.upload(dbbFile({ machine: MACHINE, test: 'yz-r150', direction: 'cw', timestamp: '2026-04-02T08:05:00Z', shape: 3, extra: yz }), 'yz_cw.txt')).id,
  };
}

// A page of its own (another token, another time zone) in the scenario's browser.
async function otherPage(browser, server, token, options = {}) {
  const context = await browser.newContext({ viewport: { width: 1280, height: 900 }, acceptDownloads: true, ...options });
  const page = await context.newPage();
  page.setDefaultTimeout(15_000);
  const errors = [];
  page.on('pageerror', (err) => errors.push(String(err)));
  page.on('console', (msg) => {
    if (msg.type() === 'error' && !/Failed to load resource/.test(msg.text())) errors.push(msg.text());
  });
  await page.goto(`${server.base}/#token=${encodeURIComponent(token)}`);
  await page.waitForSelector('body[data-ready="true"]');
  return { page, errors, close: () => context.close() };
}

test('discovery of one plane by default, a mixed choice refused unsent, no New discovery for a viewer', { timeout: 170_000 }, async () => {
  await withDashboard('page-views-discovery', async ({ server, api, page, browser, open }) => {
    const ids = await uploadTwoPlanes(api);
    await open(`#/discoveries?machine=${MACHINE}`);
    await page.waitForSelector('#disc-measurements[data-planes="ready"]');
    await page.waitForFunction(() => document.querySelectorAll('[data-testid="disc-choice"]').length === 4);
    const choices = await page.$$eval('[data-testid="disc-choice"]', (bs) => bs.map((b) => [Number(b.dataset.id), b.dataset.plane, b.checked]));
    const planeOf = Object.fromEntries(choices.map(([id, plane]) => [id, plane]));
    assert.deepEqual([planeOf[ids.xyCcw], planeOf[ids.xyCw], planeOf[ids.yzCcw], planeOf[ids.yzCw]], ['XY', 'XY', 'YZ', 'YZ']);
    const ticked = choices.filter((c) => c[2]).map((c) => c[0]).sort((a, b) => a - b);
    assert.deepEqual(ticked, [ids.yzCcw, ids.yzCw].sort((a, b) => a - b), 'the set-ups of the plane of the newest test');
    assert.equal(await page.textContent('#disc-count'), '2 of 4 chosen');

    // Two planes chosen: refused on the page, no job requested.
    const posts = [];
    page.on('request', (req) => {
      if (req.method() === 'POST' && req.url().includes('/api/v1/discoveries')) posts.push(req.postData());
    });
    await page.check(`[data-testid="disc-choice"][data-id="${ids.xyCw}"]`);
    await page.click('#disc-run');
    await page.waitForSelector('#disc-form-status.error [data-testid="disc-planes-refused"]');
    const refusal = await page.textContent('#disc-form-status');
    assert.match(refusal, /more than one plane/);
    assert.match(refusal, new RegExp(`XY \\(#${ids.xyCw}\\)`));
    assert.match(refusal, /YZ \(#\d+, #\d+\)/);
    assert.equal(posts.length, 0, 'nothing sent');
    assert.equal((await api.get('/api/v1/jobs')).items.length, 0, 'no job made');

    // One plane: sent, and the job is of that plane.
    await page.uncheck(`[data-testid="disc-choice"][data-id="${ids.xyCw}"]`);
    await page.click('#disc-run');
    await page.waitForFunction(() => /^#\/discoveries\/\d+$/.test(window.location.hash));
    const jobId = Number((await page.evaluate(() => window.location.hash)).split('/').pop());
    assert.equal(posts.length, 1);
    const job = await api.get(`/api/v1/jobs/${jobId}`);
    assert.deepEqual([...job.request.measurement_ids].sort((a, b) => a - b), [ids.yzCcw, ids.yzCw].sort((a, b) => a - b));
    await page.waitForSelector('[data-testid="disc-verdict"]', { timeout: 90_000 });
    const done = await api.get(`/api/v1/jobs/${jobId}`);
    assert.notEqual(done.status, 'failed', `the job of one plane runs: ${done.error || ''}`);
    // The engineer (here the admin) is offered a new discovery at the end.
    assert.equal(await page.isVisible('[data-testid="disc-new-again"]'), true);

    // A viewer sees the result but is not offered to start one.
    const viewer = await otherPage(browser, server, await makeToken(server, 'wall screen', 'viewer'));
    try {
      await go(viewer.page, `#/discoveries/${jobId}`);
      await viewer.page.waitForSelector('[data-testid="disc-verdict"]', { timeout: 30_000 });
      await viewer.page.waitForSelector('[data-testid="disc-actions"]');
      assert.equal(await viewer.page.isVisible('[data-testid="disc-new-again"]'), false, 'no "New discovery" for a viewer');
      assert.equal(await viewer.page.isVisible('[data-testid="discovery-new-link"]'), false);
      assert.equal(await viewer.page.isVisible('[data-testid="disc-save"]'), false);
      const actions = await viewer.page.locator('[data-testid="disc-actions"]').innerText();
      assert.doesNotMatch(actions, /New discovery/);
      await viewer.page.locator('[data-testid="discovery-view"]').screenshot({ path: join(outDir, 'page-views-viewer-discovery.png') });
      assert.deepEqual(viewer.errors, []);
    } finally {
      await viewer.close();
    }
  });
});

test('the overlay box says the server’s message; the audit PDF only with an audit', { timeout: 110_000 }, async () => {
  await withDashboard('page-views-overlay', async ({ server, api, page, open }) => {
    const ids = await uploadTwoPlanes(api);
    await open(`#/measurements/${ids.xyCcw}`);
    await page.waitForSelector(`#detail[data-view="dbb"][data-measurement-id="${ids.xyCcw}"] [data-testid="compare-form"]:not([hidden])`);
    const overlay = async (text) => {
      // The box of the previous try is cleared first, so the message read is this one's.
      await page.evaluate(() => document.querySelector('[data-testid="compare-note"]').replaceChildren());
      await page.fill('[data-testid="compare-id"]', text);
      await page.click('[data-testid="compare-add"]');
      await page.waitForSelector('[data-testid="compare-note"]:not([hidden]) [role="alert"]');
      const shown = await page.textContent('[data-testid="compare-note"]');
      assert.doesNotMatch(shown, /\[object Object\]/, `${text}: ${shown}`);
      return shown;
    };
    // The page's own check.
    let shown = await overlay('abc');
    assert.match(shown, /Not a measurement id/);
    assert.match(shown, /“abc”/);
    // The server's problem+json: its message.
    shown = await overlay('99999');
    assert.match(shown, /measurement 99999 does not exist/);
    // An answer {"error": {message, field}}: the message and the field in words.
    await page.route('**/api/v1/measurements/77777**', (route) =>
      route.fulfill({ status: 400, contentType: 'application/json', body: JSON.stringify({ error: { message: 'the id is out of range', field: 'id', line: 3, file: 'request' } }) }),
    );
    shown = await overlay('77777');
    assert.match(shown, /the id is out of range/);
    assert.match(shown, /field “id”/);
    assert.match(shown, /line 3/);
    // A good one still overlays.
    await page.fill('[data-testid="compare-id"]', String(ids.xyCw));
    await page.click('[data-testid="compare-add"]');
    await page.waitForSelector('[data-testid="compare-clear"]:not([hidden])');

    // No audit: no PDF offered (it would be a 404); the view says there are no rules.
    await go(page, `#/machines/${MACHINE}/audit`);
    await page.waitForSelector(`#audit-view:not([hidden])[data-machine-id="${MACHINE}"] [data-testid="audit-no-rules"]`);
    assert.equal(await page.isVisible('[data-testid="audit-report-pdf"]'), false, 'no audit PDF without an audit');
    const r = await fetch(`${server.base}/api/v1/machines/${MACHINE}/audit/report.pdf`, { headers: { Authorization: `Bearer ${server.token}` } });
    assert.equal(r.status, 404, 'the report the button would ask for does not exist');
    // With an audit: offered, and it is a PDF.
    const put = await fetch(`${server.base}/api/v1/machines/${MACHINE}/audit`, {
      method: 'PUT',
      headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': 'application/json' },
      body: JSON.stringify({ schedule: null, rules: [{ kind: 'dbb', metric: 'circularity_um', warn: 100 }] }),
    });
    assert.equal(put.status, 200, await put.text());
    await go(page, `#/machines/${MACHINE}`);
    await page.waitForSelector(`#machine-audit-summary [data-audit-level]`);
    await go(page, `#/machines/${MACHINE}/audit`);
    await page.waitForSelector('[data-testid="audit-report-pdf"]:visible');
    const [download] = await Promise.all([page.waitForEvent('download'), page.click('[data-testid="audit-report-pdf"]')]);
    assert.match(download.suggestedFilename(), /^kinemetric-audit-.*\.pdf$/);
    // Another machine without an audit: hidden again.
    await api.upload(dbbFile({ machine: 'views-lathe', direction: 'ccw', timestamp: '2026-04-03T08:00:00Z' }), 'lathe.txt');
    await page.reload();
    await page.waitForSelector('body[data-ready="true"]');
    await go(page, '#/machines/views-lathe/audit');
    await page.waitForSelector('#audit-view:not([hidden])[data-machine-id="views-lathe"] [data-testid="audit-no-rules"]');
    assert.equal(await page.isVisible('[data-testid="audit-report-pdf"]'), false);
  });
});

// Every "YYYY-MM-DD HH:MM" in the text is followed by " UTC" (or ":SS UTC").
function timesWithoutZone(text) {
  return [...text.matchAll(/\d{4}-\d\d-\d\d \d\d:\d\d(?::\d\d)?( UTC)?/g)].filter((m) => !m[1]).map((m) => m[0]);
}

test('every time in UTC and saying so, in a browser of another zone', { timeout: 110_000 }, async () => {
  await withDashboard('page-views-utc', async ({ server, api, browser }) => {
    const ids = await uploadTwoPlanes(api);
    const put = await fetch(`${server.base}/api/v1/machines/${MACHINE}/audit`, {
      method: 'PUT',
      headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': 'application/json' },
      body: JSON.stringify({ schedule: 'every 24h', rules: [{ kind: 'dbb', metric: 'circularity_um', warn: 0.1 }] }),
    });
    assert.equal(put.status, 200, await put.text());
    const verdict = await api.post(`/api/v1/machines/${MACHINE}/audit/run`, '{}');
    const utc = (iso) => `${new Date(iso).toISOString().slice(0, 16).replace('T', ' ')} UTC`;
    // New York in winter is UTC−5: a local time would read 03:05, not 08:05.
    const other = await otherPage(browser, server, server.token, { timezoneId: 'America/New_York', locale: 'de-DE' });
    const { page } = other;
    try {
      assert.notEqual(await page.evaluate(() => new Date('2026-04-02T08:05:00Z').getHours()), 8, 'the browser is in another zone');
      // The landing view: the newest uploads and audits.
      await page.waitForSelector('[data-testid="home-uploads"] a');
      const home = await page.textContent('#home-view');
      assert.ok(home.includes(utc(verdict.created_at)), `the audit's time in UTC: ${home}`);
      assert.deepEqual(timesWithoutZone(home), []);
      // The measurement view: measured and uploaded times.
      await go(page, `#/measurements/${ids.yzCw}`);
      await page.waitForSelector(`#detail[data-view="dbb"][data-measurement-id="${ids.yzCw}"]`);
      await page.waitForFunction(() => /2026-04-02 08:05 UTC/.test(document.querySelector('#detail').textContent));
      assert.deepEqual(timesWithoutZone(await page.textContent('#detail')), []);
      // The machine's list beside it.
      await page.waitForSelector('#measurements a, #measurements button');
      const list = await page.textContent('.sidebar');
      assert.match(list, /2026-04-02 08:05 UTC/);
      assert.deepEqual(timesWithoutZone(list), []);
      // The audit: the verdict, the next run, the history.
      await go(page, `#/machines/${MACHINE}/audit`);
      await page.waitForSelector(`#audit-view:not([hidden])[data-machine-id="${MACHINE}"] [data-testid="audit-history"]`);
      const audit = await page.textContent('#audit-view');
      assert.ok(audit.includes(utc(verdict.created_at)), `the verdict's time: ${audit}`);
      const stored = await api.get(`/api/v1/machines/${MACHINE}/audit`);
      assert.ok(audit.includes(utc(stored.next_run_at)), 'the next run in UTC');
      assert.deepEqual(timesWithoutZone(audit), []);
      // Tokens: made, last used.
      await go(page, '#/tokens');
      await page.waitForSelector('[data-testid="tokens-table"] tr[data-token-id]');
      const tokens = await page.textContent('#tokens-view');
      assert.ok(tokens.includes(utc((await api.get('/api/v1/tokens')).items[0].created_at)));
      assert.deepEqual(timesWithoutZone(tokens), []);
      // The discovery form's list gives its times without the zone under a note that says UTC.
      await go(page, `#/discoveries?machine=${MACHINE}`);
      await page.waitForSelector('#disc-measurements[data-planes="ready"] [data-testid="disc-choice"]');
      assert.match(await page.textContent('[data-testid="disc-choice-note"]'), /Times in UTC/);
      assert.match(await page.textContent('#disc-measurements'), /2026-04-02 08:05 · yz_cw\.txt/);
      await page.screenshot({ path: join(outDir, 'page-views-utc.png') });
      assert.deepEqual(other.errors, []);
    } finally {
      await other.close();
    }
  });
});
