// Browser scenario: every PDF report is a certificate (docs/http.md "Certificates"), on the page
// at 1366 and 400 px, against a real server. Two DBB tests of one set-up on different dates (the
// example file, the second a week later and warmer):
// - an engineer sees the first test's certificate "KM-M… rev 1 — draft" beside its PDF button,
//   approves it ("Approve revision 1"), then sees "approved by erin at … UTC"; the approved
//   revision is linked, and the link gives the frozen PDF (200, application/pdf);
// - the "As left" chooser offers the later test (and not the test itself), none by default;
//   choosing it makes the PDF button ask ?as_left=ID and the certificate KM-M…-L… with its own
//   revisions; an approval of the revision shown after the certificate changed (a new tolerance
//   table) is refused 409 and the server's message is shown, then the new revision is offered;
// - a machine's audit shows its certificate too;
// - a viewer sees the certificate but no Approve button;
// - at 400 px the block wraps, nothing wider than the window;
// - no console error, and no failed request but the refused approval.
//   node tests/browser/dashboard/certificates.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { assertNoHorizontalOverflow, makeToken, outDir, repo, withDashboard } from '../lib/harness.mjs';

const MACHINE = 'vmc-3axis'; // the example file's machine
const example = readFileSync(join(repo, 'data/examples/dbb_xy-r150_ccw.txt'), 'utf8');
const later = example.replace(/^# timestamp: .*$/m, '# timestamp: 2026-11-09T08:10:00Z').replace(/^# temperature_c: .*$/m, '# temperature_c: 21.3');

const go = (page, hash) =>
  page.evaluate((h) => {
    window.location.hash = h;
  }, hash);

// Every answer of 400 or more and every request that failed, of the API.
function watchFailures(page) {
  const failed = [];
  page.on('response', (r) => {
    if (r.status() >= 400 && new URL(r.url()).pathname.startsWith('/api/')) failed.push(`${r.status()} ${r.request().method()} ${r.url()}`);
  });
  page.on('requestfailed', (req) => {
    if (new URL(req.url()).pathname.startsWith('/api/')) failed.push(`failed ${req.url()}`);
  });
  return failed;
}

async function putTolerance(server, tolerance) {
  const r = await fetch(`${server.base}/api/v1/machines/${MACHINE}/tolerances`, {
    method: 'PUT',
    headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': 'application/json' },
    body: JSON.stringify({ tolerances: [{ kind: 'dbb', metric: 'circular_deviation_um', tolerance }] }),
  });
  assert.equal(r.status, 200, await r.text());
}

const block = '#certificate-measurement';
const stateText = (page) => page.textContent(`${block} [data-testid="certificate-state"]`);

// Opens the page with `token` at the measurement's view and waits for its certificate.
async function openAs(page, server, token, id) {
  await page.goto(`${server.base}/#token=${encodeURIComponent(token)}`);
  await page.waitForSelector('body[data-ready="true"]');
  await go(page, `#/measurements/${id}`);
  await page.waitForSelector(`#detail[data-measurement-id="${id}"] ${block}:not([hidden])[data-state]`);
}

// Clicks what saves a PDF: the API's answer (status, type) and the saved file's first bytes.
async function savedPdf(page, selector, pathPart) {
  const [response, download] = await Promise.all([
    page.waitForResponse((r) => r.url().includes(pathPart)),
    page.waitForEvent('download'),
    page.click(selector),
  ]);
  const head = readFileSync(await download.path()).subarray(0, 5).toString();
  return { status: response.status(), type: response.headers()['content-type'], head, name: download.suggestedFilename() };
}

test('certificates: draft, approval, approved PDF, as left, a stale approval refused, a viewer', { timeout: 170_000 }, async () => {
  await withDashboard('certificates', async ({ server, api, page, browser, errors }) => {
    const a = (await api.upload(example, 'dbb_xy-r150_ccw.txt')).id;
    const b = (await api.upload(later, 'dbb_xy-r150_ccw_week2.txt')).id;
    await putTolerance(server, 50); // a table from the start: no 404 of …/tolerances on the way
    const erin = await makeToken(server, 'erin', 'engineer');
    const vera = await makeToken(server, 'vera', 'viewer');
    const failed = watchFailures(page);
    const number = `KM-M${String(a).padStart(6, '0')}`;

    // 1366 px, an engineer: the first test's certificate, a draft, and its approval.
    await page.setViewportSize({ width: 1366, height: 900 });
    await openAs(page, server, erin, a);
    await page.waitForSelector(`${block}[data-state="draft"]`);
    assert.equal(await stateText(page), `${number} rev 1 — draft`);
    assert.equal(await page.textContent(`${block} [data-testid="certificate-approve"]`), 'Approve revision 1');
    assert.equal(await page.isVisible(`${block} [data-testid="certificate-approve"]`), true);
    assert.equal(await page.getAttribute('#report-pdf', 'data-href'), `/api/v1/measurements/${a}/report.pdf`);
    // The chooser: none by default, the later test offered, not the test itself.
    const options = await page.$$eval(`${block} [data-testid="certificate-as-left"] option`, (os) => os.map((o) => [o.value, o.textContent]));
    assert.deepEqual(options.map((o) => o[0]), ['', String(b)], JSON.stringify(options));
    assert.equal(options[0][1], 'none');
    assert.match(options[1][1], /^#\d+ CCW, measured 2026-11-09 08:10 UTC/);
    assert.equal(await page.inputValue(`${block} [data-testid="certificate-as-left"]`), '');
    await assertNoHorizontalOverflow(page, '1366 px, the certificate');
    await page.screenshot({ path: join(outDir, 'certificates-draft-1366.png') });

    await page.click(`${block} [data-testid="certificate-approve"]`);
    await page.waitForSelector(`${block}[data-state="approved"]`);
    assert.match(await stateText(page), new RegExp(`^${number} rev 1 — approved by erin at \\d{4}-\\d\\d-\\d\\d \\d\\d:\\d\\d:\\d\\d UTC$`));
    assert.match(await page.textContent(`${block} [data-testid="certificate-status"]`), /revision 1 approved by erin/);
    assert.equal(await page.$(`${block} [data-testid="certificate-approve"]`), null, 'no Approve button once approved');
    const stored = await api.get(`/api/v1/measurements/${a}/report/revisions`);
    assert.equal(stored.revisions[0].approved_by, 'erin');

    // The revisions, folded: the approved one linked to its frozen PDF.
    assert.equal(await page.textContent(`${block} [data-testid="certificate-revisions-summary"]`), 'Revisions: 1, 1 approved');
    await page.click(`${block} [data-testid="certificate-revisions-summary"]`);
    const link = `${block} [data-testid="certificate-revisions"] li[data-revision="1"] [data-testid="certificate-revision-pdf"]`;
    assert.equal(await page.getAttribute(link, 'href'), `/api/v1/measurements/${a}/report.pdf?revision=1`);
    const frozen = await savedPdf(page, link, `/measurements/${a}/report.pdf?revision=1`);
    assert.equal(frozen.status, 200);
    assert.equal(frozen.type, 'application/pdf');
    assert.equal(frozen.head, '%PDF-');

    // As left: the later test; the PDF button, the state and the approval name it.
    await page.selectOption(`${block} [data-testid="certificate-as-left"]`, String(b));
    await page.waitForSelector(`${block}[data-as-left="${b}"][data-state="draft"]`);
    const withLeft = `${number}-L${String(b).padStart(6, '0')}`;
    assert.equal(await stateText(page), `${withLeft} rev 1 — draft`);
    assert.equal(await page.getAttribute('#report-pdf', 'data-href'), `/api/v1/measurements/${a}/report.pdf?as_left=${b}`);
    const pdf = await savedPdf(page, '#report-pdf', `/measurements/${a}/report.pdf?as_left=${b}`);
    assert.deepEqual([pdf.status, pdf.type, pdf.head], [200, 'application/pdf', '%PDF-']);
    await assertNoHorizontalOverflow(page, '1366 px, as left chosen');

    // What the certificate certifies changes (a new tolerance table) while the page shows rev 1:
    // approving rev 1 is refused with the server's reason, and rev 2 is offered.
    await putTolerance(server, 40);
    const [refused] = await Promise.all([
      page.waitForResponse((r) => r.url().includes(`/measurements/${a}/report/approve?as_left=${b}`)),
      page.click(`${block} [data-testid="certificate-approve"]`),
    ]);
    assert.equal(refused.status(), 409);
    assert.deepEqual(JSON.parse(refused.request().postData()), { revision: 1 });
    const detail = (await refused.json()).detail;
    assert.ok(detail, 'the server says why');
    await page.waitForSelector(`${block} [data-testid="certificate-status"].error`);
    assert.ok((await page.textContent(`${block} [data-testid="certificate-status"]`)).includes(detail), detail);
    await page.waitForSelector(`${block}[data-revision="2"] [data-testid="certificate-approve"]`);
    assert.equal(await stateText(page), `${withLeft} rev 2 — draft`);
    assert.ok((await page.textContent(`${block} [data-testid="certificate-status"]`)).includes(detail), 'the message stays');
    await page.screenshot({ path: join(outDir, 'certificates-stale-1366.png') });
    assert.deepEqual(failed.splice(0), [`409 POST ${server.base}/api/v1/measurements/${a}/report/approve?as_left=${b}`], 'the refused approval alone failed');

    // The machine's audit has its certificate too.
    const audit = await fetch(`${server.base}/api/v1/machines/${MACHINE}/audit`, {
      method: 'PUT',
      headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': 'application/json' },
      body: JSON.stringify({ schedule: null, rules: [{ kind: 'dbb', metric: 'circularity_um', warn: 100 }] }),
    });
    assert.equal(audit.status, 200, await audit.text());
    await go(page, `#/machines/${MACHINE}/audit`);
    await page.waitForSelector('#certificate-audit:not([hidden])[data-state="draft"]');
    assert.equal(await page.textContent('#certificate-audit [data-testid="certificate-state"]'), `KM-A-${MACHINE} rev 1 — draft`);
    assert.equal(await page.isVisible('#certificate-audit [data-testid="certificate-approve"]'), true);

    // 400 px: the block wraps, the page does not scroll sideways.
    await page.setViewportSize({ width: 400, height: 860 });
    await go(page, `#/measurements/${a}`);
    await page.waitForSelector(`#detail:not([hidden])[data-measurement-id="${a}"] ${block}:not([hidden])[data-state]`);
    await page.selectOption(`${block} [data-testid="certificate-as-left"]`, '');
    await page.waitForSelector(`${block}[data-as-left=""][data-state="draft"][data-revision="2"]`);
    assert.equal(await stateText(page), `${number} rev 2 — draft`, 'the new table made rev 2 of the approved certificate');
    await assertNoHorizontalOverflow(page, '400 px, the certificate');
    await page.selectOption(`${block} [data-testid="certificate-as-left"]`, String(b));
    await page.waitForSelector(`${block}[data-as-left="${b}"][data-state="draft"][data-revision="2"]`);
    assert.equal(await page.isVisible(`${block} [data-testid="certificate-approve"]`), true);
    await assertNoHorizontalOverflow(page, '400 px, as left chosen');
    const below = await page.evaluate(() => document.querySelector('#certificate-measurement').getBoundingClientRect().top > document.querySelector('#polar-plot').getBoundingClientRect().top);
    assert.ok(below, 'at 400 px the plot comes first, the certificate after');
    await page.locator(block).screenshot({ path: join(outDir, 'certificates-400.png') });
    await page.click(`${block} [data-testid="certificate-approve"]`);
    await page.waitForSelector(`${block}[data-as-left="${b}"][data-state="approved"]`);
    await assertNoHorizontalOverflow(page, '400 px, approved');
    assert.deepEqual(failed, [], 'no failed request');

    // A viewer: the certificate and its revisions, no Approve button, at both widths.
    const context = await browser.newContext({ viewport: { width: 1366, height: 900 }, acceptDownloads: true });
    const viewer = await context.newPage();
    viewer.setDefaultTimeout(15_000);
    const viewerErrors = [];
    viewer.on('pageerror', (err) => viewerErrors.push(String(err)));
    viewer.on('console', (msg) => {
      if (msg.type() === 'error') viewerErrors.push(msg.text());
    });
    const viewerFailed = watchFailures(viewer);
    try {
      await openAs(viewer, server, vera, a);
      await viewer.waitForSelector(`${block}[data-state="draft"][data-revision="2"]`);
      assert.match(await viewer.textContent('#role-status'), /role viewer/);
      assert.equal(await viewer.$(`${block} [data-testid="certificate-approve"]`), null, 'no Approve button for a viewer');
      assert.equal(await viewer.$$eval(`${block} [data-testid="certificate-revision-pdf"]`, (as) => as.length), 1, 'rev 1 linked');
      await viewer.selectOption(`${block} [data-testid="certificate-as-left"]`, String(b));
      await viewer.waitForSelector(`${block}[data-as-left="${b}"][data-state="approved"]`);
      assert.match(await viewer.textContent(`${block} [data-testid="certificate-state"]`), / rev 2 — approved by erin at /);
      await viewer.setViewportSize({ width: 400, height: 860 });
      await viewer.selectOption(`${block} [data-testid="certificate-as-left"]`, '');
      await viewer.waitForSelector(`${block}[data-as-left=""][data-state="draft"]`);
      assert.equal(await viewer.$(`${block} [data-testid="certificate-approve"]`), null);
      await assertNoHorizontalOverflow(viewer, 'viewer, 400 px');
      assert.deepEqual(viewerFailed, [], 'no failed request for the viewer');
      assert.deepEqual(viewerErrors, [], 'no console error for the viewer');
    } finally {
      await context.close();
    }
    assert.deepEqual(errors, []);
  });
});
