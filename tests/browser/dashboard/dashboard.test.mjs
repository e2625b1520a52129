// Browser test of the kinemetric dashboard (web/static) against the real kinemetricd.
//
//   node tests/browser/dashboard/dashboard.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]
//
// Environment (all optional except the server path, which may also come from KINEMETRICD):
//   KINEMETRICD                  server binary (if not given as the first argument)
//   KINEMETRIC_WEB_DIR           folder holding package.json + node_modules (default <repo>/web)
//   KINEMETRIC_WEB_ROOT          static files served by the server (default <repo>/web/static)
//   KINEMETRIC_BROWSER_OUT       where the screenshot goes (default: second argument, else tmp)
//   KINEMETRIC_CHROMIUM          browser binary (default /usr/bin/chromium)
//
// It starts the server on a free port with a fresh data dir and a bootstrap token, drives the
// dashboard with headless Chromium (upload CCW + CW DBB files of one test through the form,
// polar plot with both traces, figures table, a bad file's validation message, a wrong
// token's 401 message), compares what is drawn with the API's numbers, takes a screenshot,
// and always stops the server. Missing prerequisites make the test FAIL with the reason.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { randomBytes } from 'node:crypto';
import { existsSync, mkdirSync, mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { createRequire } from 'node:module';
import { createServer } from 'node:net';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const repo = resolve(here, '../../..');
const serverBin = process.argv[2] || process.env.KINEMETRICD || '';
const webDir = process.env.KINEMETRIC_WEB_DIR || join(repo, 'web');
const webRoot = process.env.KINEMETRIC_WEB_ROOT || join(repo, 'web/static');
const outDir = process.env.KINEMETRIC_BROWSER_OUT || process.argv[3] || join(tmpdir(), 'kinemetric-browser');
const chromiumPath = process.env.KINEMETRIC_CHROMIUM || '/usr/bin/chromium';
const fixtures = join(repo, 'tests/fixtures/browser');
const MACHINE = 'browser-test-vmc';
const TEST_ID = 'xy-r150';
const CHROMIUM_ARGS = [
  '--headless',
  '--no-sandbox',
  '--disable-gpu',
  '--disable-quic',
  '--no-first-run',
  '--disable-background-networking',
  '--disable-component-update',
  '--disable-sync',
];

// ------------------------------------------------------------------ prerequisites

function loadPlaywright() {
  const pkg = join(webDir, 'package.json');
  if (!existsSync(join(webDir, 'node_modules', 'playwright-core'))) {
    throw new Error(
      `playwright-core is not installed in ${join(webDir, 'node_modules')}. ` +
        `Run \`npm ci\` in ${webDir} (deploy/install-deps.sh does this).`,
    );
  }
  return createRequire(pkg)('playwright-core');
}

function checkPrerequisites() {
  const problems = [];
  if (!serverBin) problems.push('no server binary given (first argument or KINEMETRICD)');
  else if (!existsSync(serverBin)) problems.push(`server binary ${serverBin} does not exist (build target kinemetricd)`);
  if (!existsSync(chromiumPath)) {
    problems.push(`${chromiumPath} is missing: install Chromium (apt-get install -y chromium; deploy/install-deps.sh)`);
  }
  if (!existsSync(join(webRoot, 'index.html'))) problems.push(`no dashboard at ${webRoot}/index.html`);
  for (const f of ['dbb_xy-r150_ccw.txt', 'dbb_xy-r150_cw.txt', 'dbb_bad_value.txt']) {
    if (!existsSync(join(fixtures, f))) problems.push(`fixture ${join(fixtures, f)} is missing`);
  }
  if (problems.length) throw new Error(`browser_dashboard cannot run:\n  - ${problems.join('\n  - ')}`);
}

// ------------------------------------------------------------------ server

function freePort() {
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

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function startServer() {
  const port = await freePort();
  const dataDir = mkdtempSync(join(tmpdir(), 'kinemetric-browser-data-'));
  const token = `bt-${randomBytes(18).toString('hex')}`;
  const log = [];
  const child = spawn(
    serverBin,
    ['--listen', `127.0.0.1:${port}`, '--data-dir', dataDir, '--web-root', webRoot],
    {
      env: { ...process.env, KINEMETRIC_BOOTSTRAP_TOKEN: token },
      stdio: ['ignore', 'pipe', 'pipe'],
    },
  );
  let exited = null;
  child.on('exit', (code, signal) => {
    exited = { code, signal };
  });
  child.on('error', (err) => {
    exited = { error: err };
  });
  child.stdout.on('data', (d) => log.push(String(d)));
  child.stderr.on('data', (d) => log.push(String(d)));
  const server = {
    child,
    port,
    dataDir,
    token,
    base: `http://127.0.0.1:${port}`,
    log: () => log.join('').slice(-4000),
    exited: () => exited,
  };
  // Wait for /healthz (up to 20 s).
  const deadline = Date.now() + 20_000;
  let last = '';
  while (Date.now() < deadline) {
    if (exited) {
      throw new Error(`kinemetricd exited before becoming healthy (${JSON.stringify(exited)}):\n${server.log()}`);
    }
    try {
      const r = await fetch(`${server.base}/healthz`);
      const body = await r.json();
      if (r.status === 200 && body.status === 'ok') return server;
      last = `HTTP ${r.status} ${JSON.stringify(body)}`;
    } catch (err) {
      last = err.message;
    }
    await sleep(100);
  }
  await stopServer(server);
  throw new Error(`kinemetricd not healthy after 20 s (last: ${last}):\n${server.log()}`);
}

async function stopServer(server) {
  if (!server) return;
  const { child } = server;
  if (child.exitCode === null && child.signalCode === null) {
    const gone = new Promise((r) => child.once('exit', r));
    child.kill('SIGTERM');
    const ok = await Promise.race([gone.then(() => true), sleep(5000).then(() => false)]);
    if (!ok) {
      child.kill('SIGKILL');
      await Promise.race([gone, sleep(2000)]);
    }
  }
  rmSync(server.dataDir, { recursive: true, force: true });
}

// ------------------------------------------------------------------ helpers

async function apiGet(server, path) {
  const r = await fetch(`${server.base}${path}`, { headers: { Authorization: `Bearer ${server.token}` } });
  assert.equal(r.status, 200, `GET ${path} → ${r.status}`);
  return r.json();
}

// The dashboard's number format for µm: 3 decimals, true minus sign, no "-0.000".
function um3(v) {
  let s = v.toFixed(3);
  if (/^-0\.?0*$/.test(s)) s = s.slice(1);
  return s.replace('-', '−');
}

// Parses "M x,y L x,y ... Z" into [[x, y], ...].
function pathPoints(d) {
  return [...d.matchAll(/[ML](-?[\d.]+),(-?[\d.]+)/g)].map((m) => [Number(m[1]), Number(m[2])]);
}

function badLineOf(text) {
  const lines = text.split('\n');
  const i = lines.findIndex((l) => /^-?[\d.]+,[^\d\s-]/.test(l));
  assert.ok(i >= 0, 'bad fixture has no non-numeric dr_um');
  return i + 1;
}

// ------------------------------------------------------------------ the test

test('dashboard: upload CCW+CW DBB, polar plot, figures, bad file, 401', { timeout: 180_000 }, async (t) => {
  checkPrerequisites();
  const { chromium } = loadPlaywright();
  mkdirSync(outDir, { recursive: true });

  let server = null;
  let browser = null;
  let page = null;
  const killOnExit = () => server?.child.kill('SIGKILL');
  process.once('exit', killOnExit);
  let failed = false;
  // Sequential steps; after a failure the rest are skipped (they depend on earlier state).
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

    const ids = {};
    for (const dir of ['ccw', 'cw']) {
      await step(`upload the ${dir.toUpperCase()} file through the form`, async () => {
        await page.setInputFiles('#upload-file', join(fixtures, `dbb_xy-r150_${dir}.txt`));
        await page.click('#upload-button');
        const msg = await page.waitForSelector('#upload-message.success');
        const text = await msg.textContent();
        const m = text.match(/#(\d+)/);
        assert.ok(m, `success message names the measurement id: "${text}"`);
        ids[dir] = Number(m[1]);
        assert.match(text, /Uploaded “dbb_xy-r150_/);
        // The dashboard shows the uploaded file's machine and selects the measurement.
        await page.waitForSelector(`#machines button[data-machine-id="${MACHINE}"][aria-current="true"]`);
        await page.waitForSelector(`#measurements button[data-id="${ids[dir]}"][aria-current="true"]`);
        await page.waitForSelector(`#polar-plot svg path[data-direction="${dir}"]`);
      });
    }

    await step('measurement list holds both directions of the test', async () => {
      const items = await page.$$eval('#measurements button[data-testid="measurement-item"]', (bs) =>
        bs.map((b) => ({ id: Number(b.dataset.id), test: b.dataset.testId, dir: b.dataset.direction, kind: b.dataset.kind })),
      );
      assert.equal(items.length, 2, JSON.stringify(items));
      assert.deepEqual(
        items.map((i) => `${i.kind}/${i.test}/${i.dir}/${i.id}`).sort(),
        [`dbb/${TEST_ID}/ccw/${ids.ccw}`, `dbb/${TEST_ID}/cw/${ids.cw}`].sort(),
      );
      const machineText = await page.textContent(`#machines button[data-machine-id="${MACHINE}"]`);
      assert.match(machineText, /2 measurements/);
    });

    await step('polar plot overlays CCW and CW with legend, scale and magnification', async () => {
      // Select the CCW one explicitly: the CW partner must be overlaid too.
      await page.click(`#measurements button[data-id="${ids.ccw}"]`);
      await page.waitForSelector(`#measurements button[data-id="${ids.ccw}"][aria-current="true"]`);
      await page.waitForSelector('#polar-plot svg path[data-direction="ccw"]');
      await page.waitForSelector('#polar-plot svg path[data-direction="cw"]');
      const plot = await page.$eval('#polar-plot svg', (svg) => ({
        umPerDiv: Number(svg.dataset.umPerDiv),
        pxPerUm: Number(svg.dataset.pxPerUm),
        nominalPx: Number(svg.dataset.nominalPx),
        magnification: Number(svg.dataset.magnification),
        nominal: svg.querySelectorAll('circle.nominal').length,
        rings: [...svg.querySelectorAll('circle.ring')].map((c) => Number(c.dataset.ringUm)),
        legend: svg.querySelector('[data-testid="plot-legend"]').textContent,
        scale: svg.querySelector('[data-testid="plot-scale"]').textContent,
        mag: svg.querySelector('[data-testid="plot-magnification"]')?.textContent,
        paths: [...svg.querySelectorAll('path.trace')].map((p) => ({
          dir: p.dataset.direction,
          d: p.getAttribute('d'),
          stroke: p.getAttribute('stroke'),
          points: Number(p.dataset.points),
        })),
      }));
      assert.equal(plot.nominal, 1, 'nominal circle drawn');
      assert.ok(plot.rings.length >= 2 && plot.rings.some((r) => r > 0) && plot.rings.some((r) => r < 0), `±rings: ${plot.rings}`);
      assert.match(plot.legend, /CCW/);
      assert.match(plot.legend, /CW \(clockwise\)/);
      assert.match(plot.scale, /^Scale \d+(\.\d+)? µm\/div$/);
      assert.equal(plot.scale, `Scale ${plot.umPerDiv} µm/div`);
      assert.match(plot.mag ?? '', /^Magnification ×[\d\u2009]+$/);
      assert.equal(plot.paths.length, 2);
      assert.notEqual(plot.paths[0].stroke, plot.paths[1].stroke, 'two colours');

      // What is drawn is the API's trace: radius = R0 + e·k at the trace's angles.
      for (const p of plot.paths) {
        const trace = await apiGet(server, `/api/v1/measurements/${ids[p.dir]}/trace`);
        assert.equal(trace.direction, p.dir);
        const n = trace.angle_deg.length;
        assert.ok(n >= 360 && n <= 720, `one turn of samples: ${n}`);
        assert.equal(p.points, n);
        const pts = pathPoints(p.d);
        assert.equal(pts.length, n);
        const tol = 0.02 / plot.pxPerUm; // the SVG keeps 0.01 px
        let worst = 0;
        for (let i = 0; i < n; ++i) {
          const [x, y] = pts[i];
          const e = (Math.hypot(x, y) - plot.nominalPx) / plot.pxPerUm;
          worst = Math.max(worst, Math.abs(e - trace.radial_error_um[i]));
          const a = (trace.angle_deg[i] * Math.PI) / 180;
          if (Math.hypot(x, y) > 1) {
            const drawn = Math.atan2(-y, x);
            const da = Math.abs(Math.atan2(Math.sin(drawn - a), Math.cos(drawn - a)));
            assert.ok(da < 1e-3, `angle of point ${i}: ${drawn} vs ${a}`);
          }
        }
        assert.ok(worst < tol, `${p.dir}: drawn radial error matches the API within ${tol} µm (worst ${worst})`);
        // Scale: the largest error fits inside the rings.
        const maxAbs = Math.max(...trace.radial_error_um.map(Math.abs));
        assert.ok(maxAbs <= 3 * plot.umPerDiv, `max |e| ${maxAbs} within ±3 div of ${plot.umPerDiv}`);
        // Magnification = (px per µm of error) / (px per µm of the circle).
        const expectMag = (plot.pxPerUm * trace.radius_mm * 1000) / plot.nominalPx;
        assert.ok(Math.abs(plot.magnification - expectMag) < 0.01, `${plot.magnification} vs ${expectMag}`);
      }
    });

    await step('figures table shows the API results for both directions', async () => {
      await page.waitForSelector('#figures table');
      const headers = await page.$$eval('#figures table thead th', (ths) => ths.map((th) => th.textContent.trim()));
      assert.deepEqual(headers.slice(2), [`CCW #${ids.ccw}`, `CW #${ids.cw}`]);
      for (const dir of ['ccw', 'cw']) {
        const res = await apiGet(server, `/api/v1/measurements/${ids[dir]}/results`);
        const trace = await apiGet(server, `/api/v1/measurements/${ids[dir]}/trace`);
        const cell = (key) => page.textContent(`#figures td[data-key="${key}"][data-direction="${dir}"]`);
        assert.equal(await cell('test_id'), TEST_ID);
        assert.equal(await cell('direction'), dir.toUpperCase());
        assert.equal(res.mode, 'centre_corrected', 'no fixed_ball_mm in the fixture');
        assert.equal(await cell('mode'), 'centre corrected');
        assert.equal(await cell('centre_offset_x_um'), um3(res.centre_offset_um[0]));
        assert.equal(await cell('centre_offset_y_um'), um3(res.centre_offset_um[1]));
        assert.equal(await cell('average_radial_error_um'), um3(res.average_radial_error_um));
        assert.equal(await cell('circularity_um'), um3(res.circularity_um));
        // Every other top-level numeric key of the results has its row too.
        for (const [k, v] of Object.entries(res)) {
          if (typeof v === 'number') assert.ok((await cell(k)) !== null, `row for ${k}`);
        }
        if (typeof res.min_zone_circularity_um === 'number') {
          assert.equal(await cell('min_zone_circularity_um'), um3(res.min_zone_circularity_um));
        }
        // Consistency of the two endpoints (radius = bar length here, seed 000 eq. 4.8):
        // circularity = max − min of the radial error about the fitted centre.
        const pv = Math.max(...trace.radial_error_um) - Math.min(...trace.radial_error_um);
        assert.ok(Math.abs(pv - res.circularity_um) < 0.01, `circularity ${res.circularity_um} vs trace p-v ${pv}`);
        // The fixture's offset (4, 2.5) µm comes from the 1st harmonic of dr; it is found
        // to well under a micrometre (it is the CW file's too).
        assert.ok(Math.abs(res.centre_offset_um[0] - 4.0) < 0.5, `offset x ${res.centre_offset_um[0]}`);
        assert.ok(Math.abs(res.centre_offset_um[1] - 2.5) < 0.5, `offset y ${res.centre_offset_um[1]}`);
      }
    });

    await step('a bad file shows the server validation message', async () => {
      const badPath = join(fixtures, 'dbb_bad_value.txt');
      const bytes = readFileSync(badPath);
      const badLine = badLineOf(bytes.toString('utf8'));
      // What the server says about it (same bytes, same file name)...
      const r = await fetch(`${server.base}/api/v1/measurements`, {
        method: 'POST',
        body: bytes,
        headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': 'text/plain', 'X-Filename': 'dbb_bad_value.txt' },
      });
      assert.equal(r.status, 400);
      assert.match(r.headers.get('content-type') || '', /application\/problem\+json/);
      const problem = await r.json();
      assert.ok(problem.detail, 'problem+json has a detail');
      assert.match(problem.detail, /dr_um/);
      assert.match(problem.detail, new RegExp(`\\b${badLine}\\b`), `detail names line ${badLine}`);
      // ...is what the dashboard shows.
      await page.setInputFiles('#upload-file', badPath);
      await page.click('#upload-button');
      const msg = await page.waitForSelector('#upload-message.error');
      assert.equal(await msg.getAttribute('role'), 'alert');
      assert.equal(await page.textContent('#upload-message .problem-detail'), problem.detail);
      if (problem.title) assert.equal(await page.textContent('#upload-message .problem-title'), problem.title);
      // The plot of the selected test stays.
      assert.equal(await page.$$eval('#polar-plot svg path.trace', (ps) => ps.length), 2);
      const list = await apiGet(server, `/api/v1/measurements?machine_id=${MACHINE}`);
      assert.equal(list.total ?? list.items.length, 2, 'bad file not stored');
    });

    await step('page fits 1280×800, screenshot', async () => {
      const shot = join(outDir, 'dashboard.png');
      await page.screenshot({ path: shot });
      assert.ok(existsSync(shot));
      t.diagnostic(`screenshot: ${shot}`);
      const overflow = await page.evaluate(() => document.documentElement.scrollWidth);
      assert.ok(overflow <= 1280, `no horizontal scrolling (scrollWidth ${overflow})`);
      const box = await page.locator('#polar-plot svg').boundingBox();
      assert.ok(box && box.x + box.width <= 1280 && box.y + box.height <= 800, `plot visible: ${JSON.stringify(box)}`);
      const tbox = await page.locator('#figures table').boundingBox();
      assert.ok(tbox && tbox.x + tbox.width <= 1280, `figures visible: ${JSON.stringify(tbox)}`);
    });

    await step('every /api/ call carried the bearer token; no script errors', async () => {
      assert.ok(apiRequests.length >= 8, `API calls seen: ${apiRequests.length}`);
      for (const r of apiRequests) assert.equal(r.auth, `Bearer ${server.token}`, r.path);
      assert.deepEqual(pageErrors, []);
    });

    await step('a wrong token shows the 401 message', async () => {
      const other = await browser.newContext({ viewport: { width: 1280, height: 800 } });
      try {
        const p2 = await other.newPage();
        await p2.goto(`${server.base}/#token=not-the-token`);
        const banner = await p2.waitForSelector('#auth-message.error', { timeout: 15_000 });
        const text = await banner.textContent();
        assert.match(text, /401/);
        assert.match(text, /token/i);
        assert.equal(await p2.$$eval('#machines button', (b) => b.length), 0);
        // Entering the right token in the box recovers.
        await p2.fill('#token-input', server.token);
        await p2.click('#token-save');
        await p2.waitForSelector(`#machines button[data-machine-id="${MACHINE}"]`);
        assert.equal(await p2.isHidden('#auth-message'), true);
        // The only machine and its newest DBB test are shown straight away.
        await p2.waitForSelector(`#measurements button[data-id="${ids.cw}"][aria-current="true"]`);
        await p2.waitForSelector('#polar-plot svg path[data-direction="ccw"]');
        await p2.screenshot({ path: join(outDir, 'dashboard-401-recovered.png') });
      } finally {
        await other.close();
      }
    });
  } finally {
    if (failed && page) {
      const shot = join(outDir, 'dashboard-failure.png');
      await page.screenshot({ path: shot }).then(() => console.error(`failure screenshot: ${shot}`), () => {});
    }
    if (browser) await browser.close().catch(() => {});
    if (failed && server) console.error(`kinemetricd log (tail):\n${server.log()}`);
    await stopServer(server);
    process.removeListener('exit', killOnExit);
  }
});
