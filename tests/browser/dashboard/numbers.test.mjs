// Browser scenario: numbers typed in the dashboard's forms are read one way everywhere
// (parseDecimal of web/static/format.js through readNumberField of dom.js): a decimal comma
// ("5,5") is 5.5, never 55; thousands separators, two commas, letters and spaces inside a number
// are refused with a message naming the field, and nothing is sent. Covered: the audit rule
// editor (warn, stop, days, the age of a stale set-up) with each limit's unit beside it, and the
// stream → straightness profile form (from, to, feed, start).
//   node tests/browser/dashboard/numbers.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { dbbFile, outDir, withDashboard } from '../lib/harness.mjs';

const MACHINE = 'numbers-vmc';

async function setLimit(page, i, key, text) {
  await page.locator('[data-testid="audit-rule-edit"]').nth(i).locator(`[data-key="${key}"]`).fill(text);
}

async function auditOf(server) {
  const r = await fetch(`${server.base}/api/v1/machines/${MACHINE}/audit`, { headers: { Authorization: `Bearer ${server.token}` } });
  return r.status === 404 ? null : r.json();
}

// Empties a message box, so that the next one waited for is the answer to the next action.
const clear = (page, testid) =>
  page.evaluate((t) => {
    const box = document.querySelector(`[data-testid="${t}"]`);
    box.className = 'message';
    box.replaceChildren();
  }, testid);

// Saves the form; the status is either an error naming `field` (nothing stored) or a success.
async function saveRefused(page, server, field, before) {
  let puts = 0;
  const count = (req) => {
    if (req.method() === 'PUT') puts += 1;
  };
  page.on('request', count);
  await clear(page, 'audit-form-status');
  await page.click('[data-testid="audit-save"]');
  await page.waitForSelector('[data-testid="audit-form-status"].error');
  page.off('request', count);
  const text = await page.textContent('[data-testid="audit-form-status"]');
  assert.ok(text.includes(field), `the message names ${field}: ${text}`);
  assert.equal(puts, 0, 'nothing is sent');
  assert.deepEqual(await auditOf(server), before, 'nothing stored');
  return text;
}

test('decimal comma read, ambiguous numbers refused naming the field, units beside limits', { timeout: 110_000 }, async () => {
  await withDashboard('numbers', async ({ server, api, page, open }) => {
    await api.upload(dbbFile({ machine: MACHINE, direction: 'ccw', timestamp: '2026-04-01T08:00:00Z' }), 'ccw.txt');
    await open(`#/machines/${MACHINE}/audit`);
    await page.waitForSelector(`#audit-view:not([hidden])[data-machine-id="${MACHINE}"] [data-testid="audit-no-rules"]`);

    // The parser itself, as the page loads it.
    const parsed = await page.evaluate(async () => {
      const { parseDecimal } = await import('/static/format.js');
      const out = {};
      for (const t of ['5,5', '5.5', ' 5.5 ', '-1,25e-3', '0,125', '1.234,5', '5,5,5', 'abc', '1 000', '12,500', '1e999', '']) out[t] = parseDecimal(t);
      return out;
    });
    assert.equal(parsed['5,5'].value, 5.5);
    assert.equal(parsed['5.5'].value, 5.5);
    assert.equal(parsed[' 5.5 '].value, 5.5);
    assert.equal(parsed['-1,25e-3'].value, -0.00125);
    assert.equal(parsed['0,125'].value, 0.125);
    for (const bad of ['1.234,5', '5,5,5', 'abc', '1 000', '12,500', '1e999']) {
      assert.equal(parsed[bad].value, undefined, `${bad} is not read as a number`);
      assert.match(parsed[bad].error, /“/, `${bad} is refused with a reason`);
    }
    assert.equal(parsed[''].empty, true);

    // The unit of each metric beside its warn and stop fields, following the metric chosen.
    const units = () => page.$$eval('[data-testid="audit-rule-edit"]:first-of-type [data-testid="audit-unit"]', (us) => us.map((u) => u.textContent));
    assert.deepEqual(await units(), ['µm', 'µm']);
    const metrics = (await api.get('/api/v1/audit-metrics')).metrics;
    const servo = metrics.find((m) => m.kind === 'servo' && m.metric === 'joint_level');
    assert.ok(servo, 'servo joint_level is a metric');
    const row = page.locator('[data-testid="audit-rule-edit"]').first();
    await row.locator('[data-key="kind"]').selectOption('servo');
    await row.locator('[data-key="metric"]').fill('joint_level');
    assert.deepEqual(await units(), [servo.unit, servo.unit]);
    await row.locator('[data-key="kind"]').selectOption('positioning');
    await row.locator('[data-key="metric"]').fill('accuracy_um.X');
    assert.deepEqual(await units(), ['µm', 'µm']);
    await row.locator('[data-key="kind"]').selectOption('dbb');
    await row.locator('[data-key="metric"]').fill('circularity_um');

    // Refused, each naming its field, nothing sent or stored.
    await setLimit(page, 0, 'stop', '');
    for (const bad of ['1.234,5', '5,5,5', 'abc', '1 000']) {
      await setLimit(page, 0, 'warn', bad);
      const text = await saveRefused(page, server, 'rules[0].warn', null);
      assert.ok(text.includes(bad), `the message quotes what was typed: ${text}`);
      assert.equal(await page.getAttribute('[data-testid="audit-rule-edit"] [data-key="warn"]', 'aria-invalid'), 'true');
    }
    await setLimit(page, 0, 'warn', '5,5');
    await setLimit(page, 0, 'stop', '12,5,0');
    await saveRefused(page, server, 'rules[0].stop', null);
    await setLimit(page, 0, 'stop', '30');
    await page.selectOption('[data-testid="audit-rule-edit"] [data-key="change"]', 'days');
    await setLimit(page, 0, 'days', '30,5');
    await saveRefused(page, server, 'rules[0].days', null);
    await page.selectOption('[data-testid="audit-rule-edit"] [data-key="change"]', '');
    await page.fill('[data-testid="audit-max-age"]', '1 000');
    await saveRefused(page, server, 'max_age_days', null);
    await page.fill('[data-testid="audit-max-age"]', '365');

    // Accepted: "5,5" is 5.5 (not 55), " 7.25 " is 7.25.
    await setLimit(page, 0, 'warn', '5,5');
    await setLimit(page, 0, 'stop', ' 7.25 ');
    await page.click('[data-testid="audit-save"]');
    await page.waitForSelector('[data-testid="audit-form-status"].success');
    const stored = await auditOf(server);
    assert.deepEqual(stored.rules.map((r) => [r.metric, r.warn, r.stop]), [['circularity_um', 5.5, 7.25]]);
    // The form shows the stored numbers again, with their unit.
    assert.equal(await page.inputValue('[data-testid="audit-rule-edit"] [data-key="warn"]'), '5.5');
    assert.match(await page.textContent('[data-testid="audit-rules"]'), /warn 5\.5, stop 7\.25 µm/);
    await page.locator('#audit-edit').screenshot({ path: join(outDir, 'numbers-audit-form.png') });

    // The stream → profile form: "0,39" is 0.39 s; a refused number names its field.
    const stream = await api.post('/api/v1/streams', JSON.stringify({ machine_id: MACHINE, name: 'numbers', channels: [{ channel: 1 }] }));
    const t0 = 1763700000000000;
    const values = Array.from({ length: 4000 }, (_, k) => 0.2 * Math.sin(k / 300));
    await api.post(`/api/v1/streams/${stream.id}/frames`, `${JSON.stringify({ channel: 1, first_counter: 0, t0_us: t0, dt_us: 100, values_um: values })}\n`, 'application/x-ndjson');
    await page.check('[data-testid="streams-all"]');
    await page.click('[data-testid="streams-refresh"]');
    const streamRow = page.locator(`[data-testid="streams-table"] tr[data-stream="${stream.id}"]`);
    await streamRow.waitFor();
    await streamRow.locator('button.link').click();
    await page.locator(`[data-testid="stream-svg"][data-stream="${stream.id}"]`).waitFor();
    const sent = [];
    page.on('request', (req) => {
      if (req.method() === 'POST' && req.url().endsWith('/profile')) sent.push(JSON.parse(req.postData()));
    });
    await page.fill('[data-testid="profile-from"]', '0');
    for (const [sel, bad, name] of [['profile-to', '0,3,9', 'To (s)'], ['profile-feed', '1.200,5', 'Feed (mm/min)'], ['profile-start', 'abc', 'Start (mm)']]) {
      await page.fill('[data-testid="profile-to"]', '0,39');
      await page.fill('[data-testid="profile-feed"]', '600');
      await page.fill('[data-testid="profile-start"]', '0');
      await page.fill(`[data-testid="${sel}"]`, bad);
      await clear(page, 'profile-message');
      await page.click('[data-testid="profile-make"]');
      await page.waitForSelector('[data-testid="profile-message"].error');
      const text = await page.textContent('[data-testid="profile-message"]');
      assert.ok(text.includes(name) && text.includes(bad), `${sel}: the message names the field and what was typed: ${text}`);
      assert.equal(await page.getAttribute(`[data-testid="${sel}"]`, 'aria-invalid'), 'true');
    }
    assert.equal(sent.length, 0, 'no profile requested with a refused number');
    await page.fill('[data-testid="profile-feed"]', ' 600,5 ');
    await page.fill('[data-testid="profile-start"]', '-1,25e-3');
    await page.click('[data-testid="profile-make"]');
    await page.waitForSelector('[data-testid="profile-message"].success');
    assert.equal(sent.length, 1);
    // 0,39 s is 390 000 µs after the first sample (not 39 s); the feed and start as typed.
    assert.equal(sent[0].to_us - sent[0].from_us, 390_000);
    assert.deepEqual(sent[0].position, { feed_mm_min: 600.5, start_mm: -0.00125 });
  });
});
