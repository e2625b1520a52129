// The dashboard browser test's session (tests/browser/dashboard/dashboard_*.test.mjs): the real
// kinemetricd on a free port with a fresh data dir and a bootstrap token, headless Chromium on
// the dashboard, the steps of one scenario run in order, and the checks every scenario ends with
// (every /api/ call carried the bearer token, no script errors). Also the fixtures and the
// dashboard's number formats the scenarios compare with.
//
// Environment (all optional except the server path, which may also come from KINEMETRICD):
//   KINEMETRICD                  server binary (if not given as the first argument)
//   KINEMETRIC_WEB_DIR           folder holding package.json + node_modules (default <repo>/web)
//   KINEMETRIC_WEB_ROOT          static files served by the server (default <repo>/web/static)
//   KINEMETRIC_BROWSER_OUT       where the screenshots go (default: second argument, else tmp)
//   KINEMETRIC_CHROMIUM          browser binary (default /usr/bin/chromium)
// Missing prerequisites make the test FAIL with the reason. Fixtures:
// tests/fixtures/browser/make_{dbb,form,tracker}_fixture(s).mjs and hexapod/ (CLI simulator).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync, mkdirSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import {
  CHROMIUM_ARGS, chromiumPath, loadPlaywright, sequentialSteps, serverBin, sleep, startServer, stopServer, webDir,
  webRoot,
} from '../lib/harness.mjs';

export { CHROMIUM_ARGS, chromiumPath, loadPlaywright, serverBin, sleep, startServer, stopServer, webDir, webRoot };

export const here = dirname(fileURLToPath(import.meta.url));
export const repo = resolve(here, '../../..');
export const outDir = process.env.KINEMETRIC_BROWSER_OUT || process.argv[3] || join(tmpdir(), 'kinemetric-browser');
export const fixtures = join(repo, 'tests/fixtures/browser');
export const MACHINE = 'browser-test-vmc';
export const TEST_ID = 'xy-r150';
export const DBB_FIXTURES = ['dbb_xy-r150_ccw.txt', 'dbb_xy-r150_cw.txt', 'dbb_bad_value.txt'];
export const FORM_FIXTURES = {
  straightness: 'straightness_x_y.txt',
  flatness: 'flatness_table.txt',
  parallelism: 'parallelism_x_tslot.txt',
};
export const TRACKER_FIXTURE = 'tracker_browser-vmc.txt'; // make_tracker_fixture.mjs
export const TRACKER_MACHINE = 'browser-vmc';
// Hexapod DBB tests: kinemetric simulate dbb --machine tests/fixtures/pm600-like.json --absolute
// --samples 180 --seed 5 --single-direction (tests a–j, CCW).
export const HEXAPOD_FIXTURES = 'abcdefghij'.split('').map((t) => `hexapod/dbb_${t}_ccw.txt`);
export const HEXAPOD_MACHINE_JSON = join(repo, 'tests/fixtures/pm600-like.json');
export const HEXAPOD_MACHINE = 'pm600-like';

// ------------------------------------------------------------------ prerequisites

export function checkPrerequisites() {
  const problems = [];
  if (!serverBin) problems.push('no server binary given (first argument or KINEMETRICD)');
  else if (!existsSync(serverBin)) problems.push(`server binary ${serverBin} does not exist (build target kinemetricd)`);
  if (!existsSync(chromiumPath)) {
    problems.push(`${chromiumPath} is missing: install Chromium (apt-get install -y chromium; deploy/install-deps.sh)`);
  }
  if (!existsSync(join(webRoot, 'index.html'))) problems.push(`no dashboard at ${webRoot}/index.html`);
  for (const f of [...DBB_FIXTURES, ...Object.values(FORM_FIXTURES), TRACKER_FIXTURE, ...HEXAPOD_FIXTURES]) {
    if (!existsSync(join(fixtures, f))) problems.push(`fixture ${join(fixtures, f)} is missing`);
  }
  if (!existsSync(HEXAPOD_MACHINE_JSON)) problems.push(`machine definition ${HEXAPOD_MACHINE_JSON} is missing`);
  if (problems.length) throw new Error(`browser_dashboard cannot run:\n  - ${problems.join('\n  - ')}`);
}

// ------------------------------------------------------------------ helpers

export async function apiGet(server, path) {
  const r = await fetch(`${server.base}${path}`, { headers: { Authorization: `Bearer ${server.token}` } });
  assert.equal(r.status, 200, `GET ${path} → ${r.status}`);
  return r.json();
}

// The dashboard's number format for µm: 3 decimals, true minus sign, no "-0.000".
export function um3(v) {
  let s = v.toFixed(3);
  if (/^-0\.?0*$/.test(s)) s = s.slice(1);
  return s.replace('-', '−');
}

// Parses "M x,y L x,y ... Z" into [[x, y], ...].
export function pathPoints(d) {
  return [...d.matchAll(/[ML](-?[\d.]+),(-?[\d.]+)/g)].map((m) => [Number(m[1]), Number(m[2])]);
}

// A number as the dashboard writes it ("−1.5", thin spaces removed) → Number.
export function shown(text) {
  return Number(String(text).replace(/\u2212/g, '-').replace(/[\s\u2009]/g, ''));
}

// The dashboard's percentage format: 1 decimal.
export function fixed1(v) {
  let s = v.toFixed(1);
  if (/^-0\.?0*$/.test(s)) s = s.slice(1);
  return s.replace('-', '−');
}

// A standard uncertainty as the dashboard writes it: two significant digits, plain notation.
export function unc2(v) {
  if (v === 0) return '0';
  const r = Number(Math.abs(v).toPrecision(2));
  const decimals = Math.min(12, Math.max(0, 1 - Math.floor(Math.log10(r))));
  let s = (Math.sign(v) * r).toFixed(decimals);
  if (/^-0\.?0*$/.test(s)) s = s.slice(1);
  return s.replace('-', '−');
}

// Diagnosis value / uncertainty as the dashboard writes them: µm-style 3 decimals, [x, y] as "x, y".
export function valueText(v) {
  return Array.isArray(v) ? v.map(um3).join(', ') : um3(v);
}

export function badLineOf(text) {
  const lines = text.split('\n');
  const i = lines.findIndex((l) => /^-?[\d.]+,[^\d\s-]/.test(l));
  assert.ok(i >= 0, 'bad fixture has no non-numeric dr_um');
  return i + 1;
}

// ------------------------------------------------------------------ a scenario

// Runs `body({ t, step, browser, page, server, pageErrors, apiRequests })` as the node:test `title`.
export function runDashboard(title, body) {
  test(`dashboard: ${title}`, { timeout: 180_000 }, async (t) => {
    checkPrerequisites();
    const { chromium } = loadPlaywright();
    mkdirSync(outDir, { recursive: true });

    let server = null;
    let browser = null;
    let page = null;
    const killOnExit = () => server?.child.kill('SIGKILL');
    process.once('exit', killOnExit);
    // The steps are sequential; after a failure the rest are skipped (they depend on earlier
    // state).
    const { step, failed } = sequentialSteps(t);

    try {
      server = await startServer();
      browser = await chromium.launch({ executablePath: chromiumPath, args: CHROMIUM_ARGS });
      const context = await browser.newContext({ viewport: { width: 1280, height: 800 } });
      page = await context.newPage();
      page.setDefaultTimeout(15_000);
      const pageErrors = [];
      const apiRequests = [];
      page.on('pageerror', (err) => pageErrors.push(String(err)));
      page.on('console', (msg) => {
        // 4xx answers to fetch() are logged by Chromium as "Failed to load resource"; expected.
        if (msg.type() === 'error' && !/Failed to load resource/.test(msg.text())) pageErrors.push(msg.text());
      });
      page.on('request', (req) => {
        const url = new URL(req.url());
        if (url.pathname.startsWith('/api/')) apiRequests.push({ path: url.pathname, auth: req.headers().authorization });
      });

      await step('server serves the dashboard and takes the token from #token=', async () => {
        await page.goto(`${server.base}/#token=${encodeURIComponent(server.token)}`);
        await page.waitForSelector('body[data-ready="true"]');
        const stored = await page.evaluate(() => localStorage.getItem('kinemetric.token'));
        assert.equal(stored, server.token, 'token stored in localStorage');
        assert.ok(!page.url().includes(server.token), `token removed from the address bar: ${page.url()}`);
        assert.equal(await page.textContent('#token-status'), 'Access token set');
        assert.equal(await page.isHidden('#auth-message'), true, 'no auth message with a good token');
        // The empty data dir lists no machine (demo data off).
        await page.waitForSelector('#machines li.empty');
      });
      await body({ t, step, browser, page, server, pageErrors, apiRequests });
      await step('every /api/ call carried the bearer token; no script errors', async () => {
        assert.ok(apiRequests.length >= 3, `API calls seen: ${apiRequests.length}`);
        for (const r of apiRequests) assert.equal(r.auth, `Bearer ${server.token}`, r.path);
        assert.deepEqual(pageErrors, []);
      });
    } finally {
      if (failed() && page) {
        const shot = join(outDir, 'dashboard-failure.png');
        await page.screenshot({ path: shot }).then(() => console.error(`failure screenshot: ${shot}`), () => {});
      }
      if (browser) await browser.close().catch(() => {});
      if (failed() && server) console.error(`kinemetricd log (tail):\n${server.log()}`);
      await stopServer(server);
      process.removeListener('exit', killOnExit);
    }
  });
}
