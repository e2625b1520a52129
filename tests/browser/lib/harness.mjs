// Shared harness of the browser scenarios: checks the prerequisites, starts kinemetricd on a free
// port with a fresh data dir and a bootstrap token, launches headless Chromium through
// playwright-core, records page errors and console errors, and always stops both. Each scenario
// file (tests/browser/dashboard/*.test.mjs) uses it and runs on its own server, so scenarios are
// independent of each other.
//
// Environment: KINEMETRICD (or the first argument) the server binary; KINEMETRIC_WEB_DIR
// (package.json + node_modules, default <repo>/web); KINEMETRIC_WEB_ROOT (default
// <repo>/web/static); KINEMETRIC_BROWSER_OUT (screenshots); KINEMETRIC_CHROMIUM (default
// /usr/bin/chromium). Missing prerequisites make the scenario FAIL with the reason.

import assert from 'node:assert/strict';
import { execFileSync, spawn } from 'node:child_process';
import { randomBytes } from 'node:crypto';
import { existsSync, mkdirSync, mkdtempSync, rmSync } from 'node:fs';
import { createRequire } from 'node:module';
import { createServer } from 'node:net';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
export const repo = resolve(here, '../../..');
export const fixtures = join(repo, 'tests/fixtures/browser');
export const serverBin = process.argv[2] || process.env.KINEMETRICD || '';
export const webDir = process.env.KINEMETRIC_WEB_DIR || join(repo, 'web');
export const webRoot = process.env.KINEMETRIC_WEB_ROOT || join(repo, 'web/static');
export const outDir = process.env.KINEMETRIC_BROWSER_OUT || process.argv[3] || join(tmpdir(), 'kinemetric-browser');
export const chromiumPath = process.env.KINEMETRIC_CHROMIUM || '/usr/bin/chromium';
export const CHROMIUM_ARGS = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync'];

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

export function loadPlaywright() {
  if (!existsSync(join(webDir, 'node_modules', 'playwright-core'))) {
    throw new Error(`playwright-core is not installed in ${join(webDir, 'node_modules')}. Run \`npm ci\` in ${webDir} (deploy/install-deps.sh does this).`);
  }
  return createRequire(join(webDir, 'package.json'))('playwright-core');
}

function checkPrerequisites() {
  const problems = [];
  if (!serverBin) problems.push('no server binary given (first argument or KINEMETRICD)');
  else if (!existsSync(serverBin)) problems.push(`server binary ${serverBin} does not exist (build target kinemetricd)`);
  if (!existsSync(chromiumPath)) problems.push(`${chromiumPath} is missing: install Chromium (deploy/install-deps.sh)`);
  if (!existsSync(join(webRoot, 'index.html'))) problems.push(`no dashboard at ${webRoot}/index.html`);
  if (problems.length) throw new Error(`browser scenario cannot run:\n  - ${problems.join('\n  - ')}`);
}

export function freePort() {
  return new Promise((res, rej) => {
    const srv = createServer();
    srv.unref();
    srv.on('error', rej);
    srv.listen(0, '127.0.0.1', () => {
      const { port } = srv.address();
      srv.close(() => res(port));
    });
  });
}

// The PostgreSQL database of a data directory when KINEMETRIC_TEST_DATABASE names a PostgreSQL
// server (tests/tools/test_database.sh creates it); none otherwise (the SQLite file).
export function databaseArgs(dataDir) {
  if (!process.env.KINEMETRIC_TEST_DATABASE) return [];
  const script = join(here, '..', '..', 'tools', 'test_database.sh');
  return ['--database', execFileSync(script, [dataDir], { encoding: 'utf8' }).trim()];
}

export async function startServer(extraArgs = []) {
  const port = await freePort();
  const dataDir = mkdtempSync(join(tmpdir(), 'kinemetric-browser-data-'));
  const token = `bt-${randomBytes(18).toString('hex')}`;
  const log = [];
  const child = spawn(serverBin, ['--listen', `127.0.0.1:${port}`, '--data-dir', dataDir, '--web-root', webRoot, ...databaseArgs(dataDir), ...extraArgs], {
    env: { ...process.env, KINEMETRIC_BOOTSTRAP_TOKEN: token },
    stdio: ['ignore', 'pipe', 'pipe'],
  });
  let exited = null;
  child.on('exit', (code, signal) => (exited = { code, signal }));
  child.on('error', (err) => (exited = { error: err }));
  child.stdout.on('data', (d) => log.push(String(d)));
  child.stderr.on('data', (d) => log.push(String(d)));
  const server = { child, port, dataDir, token, base: `http://127.0.0.1:${port}`, log: () => log.join('').slice(-4000) };
  const deadline = Date.now() + 20_000;
  while (Date.now() < deadline) {
    if (exited) throw new Error(`kinemetricd exited before becoming healthy (${JSON.stringify(exited)}):\n${server.log()}`);
    try {
      const r = await fetch(`${server.base}/healthz`);
      if (r.status === 200) return server;
    } catch {
      // not up yet
    }
    await sleep(50);
  }
  await stopServer(server);
  throw new Error(`kinemetricd not healthy after 20 s:\n${server.log()}`);
}

export async function stopServer(server) {
  if (!server) return;
  const { child } = server;
  if (child.exitCode === null && child.signalCode === null) {
    const gone = new Promise((r) => child.once('exit', r));
    child.kill('SIGTERM');
    if (!(await Promise.race([gone.then(() => true), sleep(5000).then(() => false)]))) {
      child.kill('SIGKILL');
      await Promise.race([gone, sleep(2000)]);
    }
  }
  rmSync(server.dataDir, { recursive: true, force: true });
}

// The API as the test uses it beside the page (with the token).
export function apiClient(server) {
  const headers = { Authorization: `Bearer ${server.token}` };
  return {
    async get(path) {
      const r = await fetch(`${server.base}${path}`, { headers });
      const text = await r.text();
      assert.equal(r.status, 200, `GET ${path} → ${r.status} ${text}`);
      return JSON.parse(text);
    },
    async post(path, body, type = 'application/json') {
      const r = await fetch(`${server.base}${path}`, { method: 'POST', headers: { ...headers, 'Content-Type': type }, body });
      const text = await r.text();
      assert.ok(r.ok, `POST ${path} → ${r.status} ${text}`);
      return JSON.parse(text);
    },
    async upload(text, filename) {
      const r = await fetch(`${server.base}/api/v1/measurements`, { method: 'POST', headers: { ...headers, 'Content-Type': 'text/plain', 'X-Filename': filename }, body: text });
      const out = await r.text();
      assert.ok(r.status === 201 || r.status === 200, `upload ${filename} → ${r.status} ${out}`);
      return JSON.parse(out);
    },
  };
}

// The steps of a scenario that build on each other (t.test each): after a failure the rest are
// skipped. failed() says whether one failed (for the failure screenshot and the server's log).
export function sequentialSteps(t) {
  let failed = false;
  const step = (name, fn) =>
    t.test(name, async (st) => {
      if (failed) {
        st.skip('an earlier step failed');
        return;
      }
      try {
        await fn(st);
      } catch (err) {
        failed = true;
        throw err;
      }
    });
  return { step, failed: () => failed };
}

// Runs fn({server, api, page, browser, errors, open}) with a fresh server and browser; fails on
// any page error or console error (4xx answers to fetch() are logged by Chromium as "Failed to
// load resource" and are expected). open(hash) loads the dashboard with the token at that address.
export async function withDashboard(name, fn, { viewport = { width: 1280, height: 900 }, serverArgs = [] } = {}) {
  checkPrerequisites();
  const { chromium } = loadPlaywright();
  mkdirSync(outDir, { recursive: true });
  let server = null;
  let browser = null;
  let page = null;
  const killOnExit = () => server?.child.kill('SIGKILL');
  process.once('exit', killOnExit);
  try {
    server = await startServer(serverArgs);
    browser = await chromium.launch({ executablePath: chromiumPath, args: CHROMIUM_ARGS });
    const context = await browser.newContext({ viewport, acceptDownloads: true });
    page = await context.newPage();
    page.setDefaultTimeout(15_000);
    const errors = [];
    page.on('pageerror', (err) => errors.push(String(err)));
    page.on('console', (msg) => {
      if (msg.type() === 'error' && !/Failed to load resource/.test(msg.text())) errors.push(msg.text());
    });
    const open = async (hash = '') => {
      // A goto that changes only the hash keeps the document and its view: the measurement view
      // loses its marker first, so a wait for it finds the new rendering, not the previous one
      // about to be replaced. (A fresh document would abort the old one's requests in flight.)
      if (page.url().startsWith(server.base)) {
        await page.evaluate(() => {
          const detail = document.querySelector('#detail');
          if (detail) delete detail.dataset.measurementId;
        });
      }
      await page.goto(`${server.base}/#token=${encodeURIComponent(server.token)}`);
      await page.waitForSelector('body[data-ready="true"]');
      if (hash) {
        await page.evaluate((h) => {
          window.location.hash = h;
        }, hash);
      }
    };
    await fn({ server, api: apiClient(server), page, browser, errors, open });
    assert.deepEqual(errors, [], 'no page or console errors');
  } catch (err) {
    if (page) await page.screenshot({ path: join(outDir, `${name}-failure.png`) }).catch(() => {});
    if (server) console.error(`kinemetricd log (tail):\n${server.log()}`);
    throw err;
  } finally {
    if (browser) await browser.close().catch(() => {});
    await stopServer(server);
    process.removeListener('exit', killOnExit);
  }
}

// A new token of `role` made with the server's admin token; its secret.
export async function makeToken(server, name, role) {
  const r = await fetch(`${server.base}/api/v1/tokens`, {
    method: 'POST',
    headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': 'application/json' },
    body: JSON.stringify({ name, role }),
  });
  assert.equal(r.status, 201, await r.clone().text());
  return (await r.json()).token;
}

// No element wider than the window: the page does not scroll sideways.
export async function assertNoHorizontalOverflow(page, what) {
  const { scroll, width, wide } = await page.evaluate(() => {
    const w = document.documentElement.clientWidth;
    const wideOnes = [...document.querySelectorAll('body *')]
      .filter((e) => e.offsetParent !== null && e.getBoundingClientRect().right > w + 1)
      .slice(0, 5)
      .map((e) => `${e.tagName.toLowerCase()}${e.id ? `#${e.id}` : ''}.${e.className}`);
    return { scroll: document.documentElement.scrollWidth, width: w, wide: wideOnes };
  });
  assert.ok(scroll <= width, `${what}: no horizontal overflow (scrollWidth ${scroll} > ${width}; wide: ${wide.join(', ')})`);
}

// A DBB file (kinemetric-dbb/1) of one full turn: 1st and 2nd harmonic and a small ripple;
// `shape` varies the ellipse so files differ.
export function dbbFile({ machine = 'browser-views-vmc', test = 'xy-r150', direction = 'ccw', timestamp, shape = 0, extra = [] }) {
  const deg = Math.PI / 180;
  const lines = [
    '# format: kinemetric-dbb/1',
    `# machine_id: ${machine}`,
    `# test_id: ${test}`,
    `# direction: ${direction}`,
    '# bar_length_mm: 150',
    '# centre_mm: 0, 0, 0',
    '# feed_mm_min: 1000',
    `# timestamp: ${timestamp}`,
    ...extra,
    'angle_deg,dr_um',
  ];
  for (let i = 0; i < 360; ++i) {
    const a = direction === 'ccw' ? i : -i;
    const dr = 3 * Math.cos(a * deg) + 2 * Math.sin(a * deg) + (2 + shape) * Math.cos(2 * (a - 30 - 5 * shape) * deg) + 0.3 * Math.sin(7 * a * deg) + (direction === 'cw' ? 0.6 * Math.sign(Math.sin(2 * a * deg)) : 0);
    lines.push(`${a},${dr.toFixed(3)}`);
  }
  return `${lines.join('\n')}\n`;
}
