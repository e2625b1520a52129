// Browser test of the kinemetric dashboard (web/static) against the real kinemetricd.
//
//   [KM_DASHBOARD_GROUP=dbb|form|tracker|hexapod|streams] \
//   node tests/browser/dashboard/dashboard.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]
//
// Its steps come in independent groups, each run by ctest on its own server
// (browser_dashboard_<group>); without KM_DASHBOARD_GROUP all run in order. The pair, list,
// calibration and upload scenarios are files of their own beside it.
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
// token's 401 message), the DBB diagnosis (joint CW + CCW from /pair), ISO 230-4 figures,
// harmonics and the server's PNG plot, then straightness, flatness and parallelism uploads
// with their plots and figures, then a laser-tracker upload (volumetric error vectors in XY
// and XZ, decomposition table) and a hexapod calibration job run from the "Calibrate hexapod"
// panel (before/after circularity and identified parameters = the job's result); compares
// what is drawn with the API's numbers, takes screenshots, and always stops the server.
// Missing prerequisites make the test FAIL with the reason. Fixtures:
// tests/fixtures/browser/make_{dbb,form,tracker}_fixture(s).mjs and hexapod/ (CLI simulator).

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
const DBB_FIXTURES = ['dbb_xy-r150_ccw.txt', 'dbb_xy-r150_cw.txt', 'dbb_bad_value.txt'];
const FORM_FIXTURES = {
  straightness: 'straightness_x_y.txt',
  flatness: 'flatness_table.txt',
  parallelism: 'parallelism_x_tslot.txt',
};
const TRACKER_FIXTURE = 'tracker_browser-vmc.txt'; // make_tracker_fixture.mjs
const TRACKER_MACHINE = 'browser-vmc';
// Hexapod DBB tests: kinemetric simulate dbb --machine tests/fixtures/pm600-like.json --absolute
// --samples 180 --seed 5 --single-direction (tests a–j, CCW).
const HEXAPOD_FIXTURES = 'abcdefghij'.split('').map((t) => `hexapod/dbb_${t}_ccw.txt`);
const HEXAPOD_MACHINE_JSON = join(repo, 'tests/fixtures/pm600-like.json');
const HEXAPOD_MACHINE = 'pm600-like';
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
  for (const f of [...DBB_FIXTURES, ...Object.values(FORM_FIXTURES), TRACKER_FIXTURE, ...HEXAPOD_FIXTURES]) {
    if (!existsSync(join(fixtures, f))) problems.push(`fixture ${join(fixtures, f)} is missing`);
  }
  if (!existsSync(HEXAPOD_MACHINE_JSON)) problems.push(`machine definition ${HEXAPOD_MACHINE_JSON} is missing`);
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

// A number as the dashboard writes it ("−1.5", thin spaces removed) → Number.
function shown(text) {
  return Number(String(text).replace(/\u2212/g, '-').replace(/[\s\u2009]/g, ''));
}

// The dashboard's percentage format: 1 decimal.
function fixed1(v) {
  let s = v.toFixed(1);
  if (/^-0\.?0*$/.test(s)) s = s.slice(1);
  return s.replace('-', '−');
}

// A standard uncertainty as the dashboard writes it: two significant digits, plain notation.
function unc2(v) {
  if (v === 0) return '0';
  const r = Number(Math.abs(v).toPrecision(2));
  const decimals = Math.min(12, Math.max(0, 1 - Math.floor(Math.log10(r))));
  let s = (Math.sign(v) * r).toFixed(decimals);
  if (/^-0\.?0*$/.test(s)) s = s.slice(1);
  return s.replace('-', '−');
}

// Diagnosis value / uncertainty as the dashboard writes them: µm-style 3 decimals, [x, y] as "x, y".
function valueText(v) {
  return Array.isArray(v) ? v.map(um3).join(', ') : um3(v);
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
  // The steps come in independent groups (dbb, form, tracker, hexapod, streams), each run as its
  // own ctest on its own server (KM_DASHBOARD_GROUP); without it every group runs, in order.
  // Within a group the steps are sequential; after a failure the rest are skipped (they depend
  // on earlier state). A step of groups ['*'] belongs to every group.
  const only = process.env.KM_DASHBOARD_GROUP || '';
  let group = 'dbb';
  const step = (name, fn, groups = [group]) => {
    if (only && !groups.includes(only) && !groups.includes('*')) return Promise.resolve();
    return t.test(name, async (st) => {
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
  };

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
    }, ['*']);

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
        await page.waitForSelector(`#measurements a[data-id="${ids[dir]}"][aria-current="true"]`);
        await page.waitForSelector(`#polar-plot svg path[data-direction="${dir}"]`);
      });
    }

    await step('measurement list holds both directions of the test', async () => {
      const items = await page.$$eval('#measurements a[data-testid="measurement-item"]', (bs) =>
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
      await page.click(`#measurements a[data-id="${ids.ccw}"]`);
      await page.waitForSelector(`#measurements a[data-id="${ids.ccw}"][aria-current="true"]`);
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
        // Consistency of the two endpoints (radius = bar length here, [PM-600 report] eq. 4.8):
        // circularity = max − min of the radial error about the fitted centre.
        const pv = Math.max(...trace.radial_error_um) - Math.min(...trace.radial_error_um);
        assert.ok(Math.abs(pv - res.circularity_um) < 0.01, `circularity ${res.circularity_um} vs trace p-v ${pv}`);
        // The fixture's offset (4, 2.5) µm comes from the 1st harmonic of dr; it is found
        // to well under a micrometre (it is the CW file's too).
        assert.ok(Math.abs(res.centre_offset_um[0] - 4.0) < 0.5, `offset x ${res.centre_offset_um[0]}`);
        assert.ok(Math.abs(res.centre_offset_um[1] - 2.5) < 0.5, `offset y ${res.centre_offset_um[1]}`);
      }
    });

    await step('ISO 230-4 and minimum-zone figures, pair hysteresis in the figures table', async () => {
      const pair = await apiGet(server, `/api/v1/measurements/${ids.ccw}/pair`);
      assert.equal(pair.partner_id, ids.cw, 'the CW file is the partner of the CCW file');
      for (const dir of ['ccw', 'cw']) {
        const res = await apiGet(server, `/api/v1/measurements/${ids[dir]}/results`);
        const cell = (key) => page.textContent(`#figures td[data-key="${key}"][data-direction="${dir}"]`);
        assert.equal(await cell('min_zone_circularity_um'), um3(res.min_zone_circularity_um));
        for (const k of ['circular_deviation_um', 'radial_deviation_max_um', 'radial_deviation_min_um']) {
          assert.equal(await cell(`iso230_4.${k}`), um3(res.iso230_4[k]), k);
        }
        // Minimum zone never exceeds the least-squares circularity.
        assert.ok(res.min_zone_circularity_um <= res.circularity_um + 1e-9);
      }
      const label = await page.textContent('#figures tr[data-key="iso230_4.circular_deviation_um"] th');
      assert.match(label, /ISO 230-4/);
      for (const k of ['circular_hysteresis_um', 'bidirectional_circular_deviation_um']) {
        assert.equal(await page.textContent(`#figures td[data-testid="pair-${k}"]`), um3(pair.pair[k]), k);
      }
    });

    await step('diagnosis table and contribution chart show the joint CW + CCW diagnosis', async () => {
      const pair = await apiGet(server, `/api/v1/measurements/${ids.ccw}/pair`);
      const res = await apiGet(server, `/api/v1/measurements/${ids.ccw}/results`);
      await page.waitForSelector('#analysis:not([hidden])');
      assert.equal(await page.getAttribute('#diagnosis-source', 'data-source'), 'pair');
      assert.match(await page.textContent('#diagnosis-source'), /Joint diagnosis of CW and CCW/);
      const expected = [...pair.joint_diagnosis].sort((a, b) => b.contribution_pct - a.contribution_pct);
      assert.ok(expected.length >= 1, `the fixtures have named effects: ${JSON.stringify(pair.joint_diagnosis)}`);
      await page.waitForSelector('#diagnosis-table-box table[data-source="pair"]');
      const rows = await page.$$eval('#diagnosis-table-box tbody tr', (trs) =>
        trs.map((tr) => ({
          effect: tr.dataset.effect,
          name: tr.querySelector('.effect-name').textContent,
          words: tr.querySelector('.effect-words').textContent,
          value: tr.querySelector('td[data-key="value"]').textContent,
          uncertainty: tr.querySelector('td[data-key="uncertainty"]').textContent,
          pct: tr.querySelector('td[data-key="contribution_pct"]').textContent,
        })),
      );
      assert.deepEqual(rows.map((r) => r.effect), expected.map((d) => d.effect), 'ranked by contribution');
      rows.forEach((r, i) => {
        const d = expected[i];
        assert.equal(r.name, d.effect);
        assert.ok(r.words.length > 0 && r.words !== d.effect, `effect in words: ${r.words}`);
        assert.equal(r.value, valueText(d.value), `${d.effect} value`);
        assert.equal(r.uncertainty, `± ${Array.isArray(d.uncertainty) ? d.uncertainty.map(unc2).join(', ') : unc2(d.uncertainty)}`, `${d.effect} uncertainty`);
        assert.equal(r.pct, fixed1(d.contribution_pct), `${d.effect} contribution`);
      });
      const bars = await page.$$eval('#contribution-chart svg g.bar', (gs) =>
        gs.map((g) => ({ effect: g.dataset.effect, pct: Number(g.dataset.pct), width: Number(g.querySelector('rect').getAttribute('width')), rest: g.classList.contains('rest') })),
      );
      const named = bars.filter((b) => !b.rest);
      assert.deepEqual(named.map((b) => b.effect), expected.map((d) => d.effect));
      named.forEach((b, i) => assert.equal(b.pct, expected[i].contribution_pct));
      // Bar lengths are proportional to the contributions.
      const scale = named[0].width / named[0].pct;
      for (const b of named) assert.ok(Math.abs(b.width - b.pct * scale) < 0.05, `bar ${b.effect}`);
      const total = expected.reduce((s, d) => s + d.contribution_pct, 0);
      const rest = bars.find((b) => b.rest);
      assert.ok(rest && Math.abs(rest.pct - Math.max(0, 100 - total)) < 1e-9, 'unexplained share drawn');
      // Effects that cannot be told apart are listed (muted) when the analysis says so.
      const ni = res.not_identifiable || [];
      assert.equal(await page.isHidden('#not-identifiable'), ni.length === 0);
      for (const n of ni) assert.ok((await page.textContent('#not-identifiable')).includes(n.split(' ')[0]));
    });

    await step('harmonics chart shows the amplitudes of both directions', async () => {
      const drawn = await page.$$eval('#harmonics-chart svg rect[data-order]', (rs) =>
        rs.map((r) => ({ order: Number(r.dataset.order), dir: r.dataset.direction, amp: Number(r.dataset.amplitudeUm), h: Number(r.getAttribute('height')) })),
      );
      let count = 0;
      for (const dir of ['ccw', 'cw']) {
        const res = await apiGet(server, `/api/v1/measurements/${ids[dir]}/results`);
        for (const k of res.harmonics) {
          const bar = drawn.find((b) => b.dir === dir && b.order === k.order);
          assert.ok(bar, `bar for ${dir} order ${k.order}`);
          assert.equal(bar.amp, k.amplitude_um);
          ++count;
        }
        // The fixture's 2nd harmonic (oval, 3.0 / 2.4 µm) shows.
        const second = res.harmonics.find((k) => k.order === 2);
        assert.ok(second && second.amplitude_um > 1.5, `2nd harmonic ${JSON.stringify(second)}`);
      }
      assert.equal(drawn.length, count);
      const tallest = drawn.reduce((a, b) => (b.amp > a.amp ? b : a));
      const ratio = tallest.h / tallest.amp;
      for (const b of drawn) assert.ok(Math.abs(b.h - b.amp * ratio) < 0.05, `height of ${b.dir} ${b.order}`);
    });

    await step('plot.png opens through an authorised fetch', async () => {
      await page.click('#plot-png-button');
      await page.waitForSelector('#png-dialog[open]');
      await page.waitForFunction(() => {
        const img = document.querySelector('#png-image');
        return img.complete && img.naturalWidth > 0;
      });
      const img = await page.$eval('#png-image', (i) => ({ src: i.src, w: i.naturalWidth, h: i.naturalHeight, id: i.dataset.measurementId }));
      assert.match(img.src, /^blob:/);
      assert.equal(Number(img.id), ids.ccw);
      assert.ok(img.w >= 200 && img.h >= 200, `PNG size ${img.w}×${img.h}`);
      await page.screenshot({ path: join(outDir, 'dashboard-png.png') });
      await page.click('#png-close');
      await page.waitForSelector('#png-dialog:not([open])', { state: 'attached' });
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
      await page.screenshot({ path: join(outDir, 'dashboard-dbb-full.png'), fullPage: true });
      const overflow = await page.evaluate(() => document.documentElement.scrollWidth);
      assert.ok(overflow <= 1280, `no horizontal scrolling (scrollWidth ${overflow})`);
      const box = await page.locator('#polar-plot svg').boundingBox();
      assert.ok(box && box.x + box.width <= 1280 && box.y + box.height <= 800, `plot visible: ${JSON.stringify(box)}`);
      const tbox = await page.locator('#figures table').boundingBox();
      assert.ok(tbox && tbox.x + tbox.width <= 1280, `figures visible: ${JSON.stringify(tbox)}`);
    });

    group = 'form';
    const formIds = {};
    const uploadForm = async (kind) => {
      await page.setInputFiles('#upload-file', join(fixtures, FORM_FIXTURES[kind]));
      await page.click('#upload-button');
      const msg = await page.waitForSelector(`#upload-message.success:has-text("${FORM_FIXTURES[kind]}")`);
      const m = (await msg.textContent()).match(/#(\d+)/);
      assert.ok(m, 'success message names the id');
      formIds[kind] = Number(m[1]);
      await page.waitForSelector(`#measurements a[data-id="${formIds[kind]}"][aria-current="true"]`);
      await page.waitForSelector(`#figures table[data-kind="${kind}"]`);
      assert.equal(await page.isHidden('#analysis'), true, 'no DBB diagnosis for a form measurement');
      const [meas, res] = await Promise.all([
        apiGet(server, `/api/v1/measurements/${formIds[kind]}`),
        apiGet(server, `/api/v1/measurements/${formIds[kind]}/results`),
      ]);
      assert.equal(meas.kind, kind);
      const cell = (key) => page.textContent(`#figures td[data-key="${key}"][data-id="${formIds[kind]}"]`);
      return { meas, res, cell };
    };

    await step('straightness upload: profile about the LS line, minimum zone, figures', async () => {
      const { meas, res, cell } = await uploadForm('straightness');
      await page.waitForSelector('#polar-plot svg[data-testid="profile-plot"]');
      for (const k of ['straightness_lsq_um', 'straightness_min_zone_um', 'straightness_end_point_um', 'slope_um_per_m']) {
        assert.equal(await cell(k), um3(res[k]), k);
      }
      // The fixture: slope 12 µm/m plus the bow's zero net slope; waviness 55 mm, 0.2 µm.
      assert.ok(Math.abs(res.slope_um_per_m - 12) < 0.5, `slope ${res.slope_um_per_m}`);
      const wave = res.periodic.find((p) => Math.abs(p.period_mm - 55) < 2);
      assert.ok(wave && Math.abs(wave.amplitude_um - 0.2) < 0.03, `55 mm waviness: ${JSON.stringify(res.periodic)}`);
      const periodicRows = await page.$$eval('[data-testid="periodic-table"] tbody tr[data-index]', (trs) =>
        trs.map((tr) => Object.fromEntries([...tr.querySelectorAll('td')].map((td) => [td.dataset.key, td.textContent]))),
      );
      assert.equal(periodicRows.length, res.periodic.length);
      res.periodic.forEach((p, i) => {
        assert.equal(periodicRows[i].period_mm, um3(p.period_mm));
        assert.equal(periodicRows[i].amplitude_um, um3(p.amplitude_um));
        assert.equal(periodicRows[i].peak_to_valley_um, um3(2 * p.amplitude_um));
      });
      const plot = await page.$eval('#polar-plot svg', (svg) => ({
        points: Number(svg.querySelector('[data-testid="profile-trace"]').dataset.points),
        ls: svg.querySelectorAll('[data-testid="ls-line"]').length,
        zone: svg.querySelector('[data-testid="min-zone-band"]')?.dataset.widthUm,
        text: svg.textContent,
      }));
      assert.equal(plot.points, meas.samples.position_mm.length);
      assert.equal(plot.points, 201);
      assert.equal(plot.ls, 1, 'least-squares zero line');
      assert.ok(plot.zone !== undefined, 'minimum-zone band drawn');
      assert.ok(Math.abs(Number(plot.zone) - res.straightness_min_zone_um) < 1e-3, `zone ${plot.zone} vs ${res.straightness_min_zone_um}`);
      assert.match(plot.text, /Position along X \(mm\)/);
      assert.match(plot.text, /\(µm\)/);
      await page.screenshot({ path: join(outDir, 'dashboard-straightness.png') });
    });

    await step('flatness upload: colour map about the LS plane with a µm scale, figures', async () => {
      const { meas, res, cell } = await uploadForm('flatness');
      await page.waitForSelector('#polar-plot svg[data-testid="flatness-map"]');
      for (const k of ['flatness_lsq_um', 'flatness_min_zone_um', 'range_um']) assert.equal(await cell(k), um3(res[k]), k);
      for (const k of ['slope_x_um_per_m', 'slope_y_um_per_m', 'offset_um']) assert.equal(await cell(`plane.${k}`), um3(res.plane[k]), k);
      const cells = await page.$$eval('#polar-plot svg .cells [data-um]', (cs) =>
        cs.map((c) => ({ x: Number(c.dataset.xMm), y: Number(c.dataset.yMm), um: Number(c.dataset.um), fill: c.getAttribute('fill') })),
      );
      const { x_mm: xs, y_mm: ys, z_um: zs } = meas.samples;
      assert.equal(cells.length, zs.length);
      assert.equal(cells.length, 63);
      const p = res.plane;
      for (let i = 0; i < zs.length; ++i) {
        const c = cells.find((q) => q.x === xs[i] && q.y === ys[i]);
        const expectUm = zs[i] - (p.offset_um + (p.slope_x_um_per_m / 1000) * xs[i] + (p.slope_y_um_per_m / 1000) * ys[i]);
        assert.ok(c && Math.abs(c.um - expectUm) < 1e-9, `cell ${xs[i]},${ys[i]}`);
      }
      // Peak to valley of the drawn deviations is the least-squares flatness.
      const pv = Math.max(...cells.map((c) => c.um)) - Math.min(...cells.map((c) => c.um));
      assert.ok(Math.abs(pv - res.flatness_lsq_um) < 1e-6, `${pv} vs ${res.flatness_lsq_um}`);
      assert.ok(new Set(cells.map((c) => c.fill)).size > 5, 'colours vary');
      const scale = await page.textContent('#polar-plot [data-testid="colour-scale"]');
      assert.match(scale, /µm/);
      await page.screenshot({ path: join(outDir, 'dashboard-flatness.png') });
    });

    await step('parallelism upload: readings from the datum with the LS line, figures', async () => {
      const { meas, res, cell } = await uploadForm('parallelism');
      await page.waitForSelector('#polar-plot svg[data-testid="profile-plot"]');
      for (const k of ['parallelism_um', 'slope_um_per_m', 'straightness_lsq_um']) assert.equal(await cell(k), um3(res[k]), k);
      const band = await page.$eval('#polar-plot [data-testid="parallelism-band"]', (b) => Number(b.dataset.widthUm));
      const d = meas.samples.deviation_um;
      assert.ok(Math.abs(band - res.parallelism_um) < 1e-9);
      assert.ok(Math.abs(Math.max(...d) - Math.min(...d) - res.parallelism_um) < 1e-9);
      await page.screenshot({ path: join(outDir, 'dashboard-parallelism.png') });
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
        await p2.waitForSelector(`#measurements a[data-id="${ids.cw}"][aria-current="true"]`);
        await p2.waitForSelector('#polar-plot svg path[data-direction="ccw"]');
        await p2.screenshot({ path: join(outDir, 'dashboard-401-recovered.png') });
      } finally {
        await other.close();
      }
    }, ['dbb']);

    group = 'tracker';
    await step('tracker upload: volumetric error vectors in XY and XZ, decomposition, figures', async () => {
      await page.setInputFiles('#upload-file', join(fixtures, TRACKER_FIXTURE));
      await page.click('#upload-button');
      const msg = await page.waitForSelector(`#upload-message.success:has-text("${TRACKER_FIXTURE}")`);
      const m = (await msg.textContent()).match(/#(\d+)/);
      assert.ok(m, 'success message names the id');
      const id = Number(m[1]);
      await page.waitForSelector(`#machines button[data-machine-id="${TRACKER_MACHINE}"][aria-current="true"]`);
      await page.waitForSelector(`#measurements a[data-id="${id}"][aria-current="true"]`);
      await page.waitForSelector('#polar-plot svg[data-testid="tracker-vector-plot"]');
      await page.waitForSelector('#figures table[data-kind="tracker"]');
      assert.equal(await page.isHidden('#analysis'), true, 'no DBB diagnosis for a tracker measurement');
      assert.equal(await page.isHidden('#calibration'), true, 'no hexapod panel without DBB tests');
      const [meas, res] = await Promise.all([
        apiGet(server, `/api/v1/measurements/${id}`),
        apiGet(server, `/api/v1/measurements/${id}/results`),
      ]);
      assert.equal(meas.kind, 'tracker');
      const { x_mm: xs, y_mm: ys, z_mm: zs } = meas.samples;
      const errors = res.volumetric_error_um;
      assert.equal(xs.length, 64, '4×4×4 commanded points');
      assert.equal(errors.length, xs.length);
      const plot = await page.$eval('#polar-plot svg', (svg) => ({
        pxPerUm: Number(svg.dataset.pxPerUm),
        pxPerMm: Number(svg.dataset.pxPerMm),
        magnification: Number(svg.dataset.magnification),
        mag: svg.querySelector('[data-testid="tracker-magnification"]').textContent,
        bar: { um: Number(svg.querySelector('[data-testid="tracker-scale"]').dataset.barUm), px: Number(svg.querySelector('[data-testid="tracker-scale"]').dataset.barPx), text: svg.querySelector('[data-testid="tracker-scale"]').textContent },
        views: [...svg.querySelectorAll('g.view')].map((g) => g.dataset.view),
        dots: svg.querySelectorAll('g.view circle[data-point]').length,
        vectors: [...svg.querySelectorAll('line.vector[data-point]')].map((l) => ({
          view: l.dataset.view,
          i: Number(l.dataset.point),
          e1: l.dataset.e1Um,
          e2: l.dataset.e2Um,
          x1: Number(l.getAttribute('x1')),
          y1: Number(l.getAttribute('y1')),
          x2: Number(l.getAttribute('x2')),
          y2: Number(l.getAttribute('y2')),
        })),
      }));
      assert.deepEqual(plot.views, ['xy', 'xz']);
      assert.equal(plot.dots, 2 * xs.length, 'every commanded point in both views');
      // Hovering a point gives its position and error in numbers.
      const k = errors.findIndex((e) => Array.isArray(e));
      const hover = await page.textContent(`#polar-plot svg g.view[data-view="xy"] circle[data-hit-point="${k}"] title`);
      const e0 = errors[k];
      const f3 = (v) => v.toFixed(3).replace('-', '−');
      assert.equal(
        hover,
        `Point ${k + 1} at X ${f3(xs[k])}, Y ${f3(ys[k])}, Z ${f3(zs[k])} mm: error X ${f3(e0[0])}, Y ${f3(e0[1])}, Z ${f3(e0[2])} µm (${f3(Math.hypot(...e0))} µm)`,
      );
      // One Z layer at a time, and back to all.
      const layerZ = Math.max(...zs);
      await page.selectOption('[data-testid="tracker-layer"]', String(layerZ));
      await page.waitForSelector(`#polar-plot svg[data-testid="tracker-vector-plot"][data-layer="${layerZ}"]`);
      const inLayer = zs.filter((z) => z === layerZ).length;
      assert.equal(await page.locator('#polar-plot svg[data-testid="tracker-vector-plot"] g.view circle[data-point]').count(), 2 * inLayer);
      await page.selectOption('[data-testid="tracker-layer"]', 'all');
      await page.waitForSelector('#polar-plot svg[data-testid="tracker-vector-plot"][data-layer="all"]');
      assert.ok(plot.magnification >= 1000, `magnification ${plot.magnification}`);
      assert.equal(plot.pxPerUm, plot.magnification * 1e-3 * plot.pxPerMm);
      assert.match(plot.mag, new RegExp(`×${plot.magnification}\\b`));
      assert.ok(Math.abs(plot.bar.px - plot.bar.um * plot.pxPerUm) < 1e-9, 'scale bar length');
      assert.ok(plot.bar.px >= 40 && plot.bar.px <= 130, `scale bar ${plot.bar.px} px`);
      assert.match(plot.bar.text, new RegExp(`^${plot.bar.um} µm$`));
      const kept = errors.filter(Boolean).length;
      assert.ok(kept > 0 && kept <= xs.length, `${kept} points with an error`);
      const tol = 0.02 / plot.pxPerUm; // coordinates are kept to 0.01 px
      for (const [view, a, b, pos] of [['xy', 0, 1, ys], ['xz', 0, 2, zs]]) {
        const lines = plot.vectors.filter((v) => v.view === view);
        assert.equal(lines.length, kept, `${view}: one arrow per kept point`);
        const first = lines.find((v) => v.i === 0) || lines[0];
        for (const v of lines) {
          const e = errors[v.i];
          assert.ok(e, `point ${v.i} has an error`);
          // The arrow is the API's error to 3 decimals...
          assert.equal(um3(Number(v.e1)), um3(e[a]), `${view} point ${v.i} e${a}`);
          assert.equal(um3(Number(v.e2)), um3(e[b]), `${view} point ${v.i} e${b}`);
          assert.ok(Math.abs((v.x2 - v.x1) / plot.pxPerUm - e[a]) <= tol, `${view} arrow ${v.i} along ${a}`);
          assert.ok(Math.abs(-(v.y2 - v.y1) / plot.pxPerUm - e[b]) <= tol, `${view} arrow ${v.i} along ${b}`);
          // ...drawn at the commanded point (same mm scale in both directions, y up).
          assert.ok(Math.abs(v.x1 - first.x1 - (xs[v.i] - xs[first.i]) * plot.pxPerMm) < 0.02, `${view} x of point ${v.i}`);
          assert.ok(Math.abs(-(v.y1 - first.y1) - (pos[v.i] - pos[first.i]) * plot.pxPerMm) < 0.02, `${view} y of point ${v.i}`);
        }
      }
      // Decomposition table = results.decomposition, 3 decimals, ± σ.
      const dec = res.decomposition;
      const rows = await page.$$eval('[data-testid="decomposition-table"] tbody tr[data-key]', (trs) =>
        trs.map((tr) => ({ key: tr.dataset.key, value: tr.querySelector('td[data-key="value"]').textContent, sigma: tr.querySelector('td[data-key="sigma"]').textContent })),
      );
      const expected = [
        ...['x', 'y', 'z'].map((k) => [`scale_ppm.${k}`, dec.scale_ppm[k], dec.scale_sigma_ppm[k]]),
        ...['xy', 'yz', 'zx'].map((k) => [`squareness_um_per_m.${k}`, dec.squareness_um_per_m[k], dec.squareness_sigma_um_per_m[k]]),
      ];
      assert.deepEqual(rows.map((r) => r.key), expected.map((e) => e[0]));
      rows.forEach((r, i) => {
        assert.equal(r.value, um3(expected[i][1]), r.key);
        assert.equal(r.sigma, `± ${unc2(expected[i][2])}`, `${r.key} σ`);
      });
      // The fixture's squareness (XY 8 µm/m, ZX −5 µm/m) and Z scale (6 ppm) are recovered.
      assert.ok(Math.abs(Math.abs(dec.squareness_um_per_m.xy) - 8) < 1, `xy ${dec.squareness_um_per_m.xy}`);
      assert.ok(Math.abs(Math.abs(dec.squareness_um_per_m.zx) - 5) < 1, `zx ${dec.squareness_um_per_m.zx}`);
      assert.ok(Math.abs(dec.scale_ppm.z - 6) < 1, `scale z ${dec.scale_ppm.z}`);
      const cell = (key) => page.textContent(`#figures td[data-key="${key}"][data-id="${id}"]`);
      assert.equal(await cell('residual_rms_um'), um3(res.residual_rms_um));
      assert.equal(shown(await cell('condition_number')).toFixed(3), res.condition_number.toFixed(3));
      assert.equal(await cell('rejected_readings_count'), String(res.rejected_readings.length));
      await page.screenshot({ path: join(outDir, 'dashboard-tracker.png') });
    });

    await step('tracker: geometric error components along X, Y, Z (curves = decomposition terms)', async () => {
      // The tracker measurement of the previous step is still selected.
      const id = Number(await page.getAttribute('#measurements a[aria-current="true"]', 'data-id'));
      const res = await apiGet(server, `/api/v1/measurements/${id}/results`);
      const dec = res.decomposition;
      assert.ok(dec && Array.isArray(dec.terms), 'results carry a decomposition with terms');
      await page.waitForSelector('#polar-plot [data-testid="component-charts"] svg[data-testid="component-chart"]');
      const charts = await page.$$eval('#polar-plot svg[data-testid="component-chart"]', (svgs) =>
        svgs.map((svg) => ({
          axis: svg.dataset.axis,
          lo: Number(svg.dataset.loMm),
          hi: Number(svg.dataset.hiMm),
          pxPerUm: Number(svg.dataset.pxPerUm),
          zeroPx: Number(svg.dataset.zeroPx),
          zeroY: Number(svg.querySelector('[data-testid="component-zero"]')?.getAttribute('y1')),
          legend: svg.querySelector('[data-testid="component-legend"]')?.textContent || '',
          titles: [...svg.querySelectorAll('text.axis-title')].map((t) => t.textContent),
          bands: svg.querySelectorAll('polygon, .band').length,
          curves: [...svg.querySelectorAll('g.components-curves path')].map((p) => ({
            direction: p.dataset.direction,
            kind: p.dataset.kind,
            pair: p.dataset.pair || null,
            ends: JSON.parse(p.dataset.endValues),
            d: p.getAttribute('d'),
          })),
        })),
      );
      assert.deepEqual(charts.map((c) => c.axis), ['x', 'y', 'z'], 'one component chart per axis');
      // Independent evaluation at the axis ends t = ±1, where P_k(±1) = (±1)^k (Legendre basis):
      //   positioning  E_AA = 1e-3·scale_ppm·(±h) + Σ c_k (±1)^k
      //   straightness E_BA = Σ c_k (±1)^k           squareness share in B: −½·1e-3·S_AB·(±h)
      const pairs = { xy: ['x', 'y'], yz: ['y', 'z'], zx: ['z', 'x'] };
      const checked = [];
      charts.forEach((c, i) => {
        const a = c.axis;
        const A = a.toUpperCase();
        const centre = dec.centre_mm[i];
        const half = dec.half_range_mm[i];
        assert.ok(half > 0, `${a} moves`);
        assert.ok(Math.abs(c.lo - (centre - half)) < 1e-9 && Math.abs(c.hi - (centre + half)) < 1e-9, `${a} range`);
        assert.ok(c.titles.includes(`${A} position (mm)`) && c.titles.includes('Error (µm)'), `${a} axis titles ${c.titles}`);
        assert.ok(Math.abs(c.zeroY - Math.round(c.zeroPx * 100) / 100) < 1e-9, `${a} zero line`);
        assert.equal(c.bands, 0, 'no ±1σ band (correlated terms, no covariance reported)');
        const solid = c.curves.filter((k) => k.kind !== 'squareness');
        assert.deepEqual(solid.map((k) => [k.direction, k.kind]).sort(), ['x', 'y', 'z'].map((b) => [b, b === a ? 'positioning' : 'straightness']));
        const shares = c.curves.filter((k) => k.kind === 'squareness');
        const wantPairs = Object.keys(pairs).filter((p) => pairs[p].includes(a) && !dec.fixed.some((f) => f.startsWith(`squareness_${p}`)));
        assert.deepEqual(shares.map((k) => k.pair).sort(), wantPairs.sort(), `${a} squareness shares`);
        for (const k of c.curves) {
          const b = k.direction;
          const expect = [-1, 1].map((sgn) => {
            if (k.kind === 'squareness') return -0.5e-3 * dec.squareness_um_per_m[k.pair] * sgn * half;
            let v = b === a ? 1e-3 * dec.scale_ppm[a] * sgn * half : 0;
            for (const t of dec.terms) if (t.axis === a && t.direction === b) v += t.value_um * sgn ** t.order;
            return v;
          });
          const tag = `${a}: E${b.toUpperCase()}${A} ${k.kind}${k.pair ? ` ${k.pair}` : ''}`;
          assert.equal(k.ends.length, 2, tag);
          k.ends.forEach((v, j) => assert.ok(Math.abs(v - expect[j]) < 1e-6, `${tag} end ${j}: drawn ${v}, from the terms ${expect[j]}`));
          // ...and that is what is drawn: first/last path vertex at the ends, µm → px.
          const pts = pathPoints(k.d);
          assert.ok(pts.length >= 50, `${tag} sampled`);
          for (const [j, pt] of [[0, pts[0]], [1, pts[pts.length - 1]]]) {
            assert.ok(Math.abs(c.zeroPx - pt[1] - expect[j] * c.pxPerUm) < 0.011, `${tag} end ${j} at ${pt[1]} px`);
          }
          checked.push(tag);
        }
        assert.match(c.legend, new RegExp(`E${A}${A} positioning`), `${a} legend`);
      });
      assert.equal(checked.length, 3 * 3 + 3 * 2, 'three curves and two squareness shares per axis');
      // The fixture's Z scale error (6 ppm) shows as the slope of E_ZZ: ≈ ±0.9 µm at z = ±150 mm.
      const ezz = charts[2].curves.find((k) => k.kind === 'positioning').ends;
      assert.ok(Math.abs(ezz[1] - ezz[0] - 1e-3 * 6 * 2 * dec.half_range_mm[2]) < 0.2, `E_ZZ ends ${ezz}`);
      // Uncertainty: no band, per-term σ in the table; fixed components named under the charts.
      const notes = await page.textContent('[data-testid="component-uncertainty"]');
      assert.match(notes, /uncertainty per term in the table/);
      const cells = await page.$$eval('[data-testid="component-terms"] tbody td[data-order]', (tds) =>
        tds.map((td) => ({ axis: td.closest('tr').dataset.axis, direction: td.closest('tr').dataset.direction, order: Number(td.dataset.order), key: td.dataset.key, text: td.textContent })),
      );
      const cell = (t, key) => cells.find((c) => c.axis === t.axis && c.direction === t.direction && c.order === t.order && c.key === key)?.text;
      for (const t of dec.terms) {
        assert.equal(cell(t, 'value'), um3(t.value_um), `term ${t.axis}${t.direction} order ${t.order}`);
        assert.equal(cell(t, 'sigma'), `± ${unc2(t.sigma_um)}`, `σ of term ${t.axis}${t.direction} order ${t.order}`);
      }
      assert.equal(cells.filter((c) => c.key === 'value' && c.text !== '—').length, dec.terms.length, 'one table cell per term');
      const fixedBox = await page.$eval('[data-testid="component-charts"]', (box) => ({
        text: box.textContent,
        items: [...box.querySelectorAll('[data-testid="component-fixed"] li')].map((li) => li.textContent),
      }));
      assert.deepEqual(fixedBox.items, dec.fixed);
      assert.match(fixedBox.text, /not identifiable from this map \(held at zero\)/i);
      const box = await page.$('[data-testid="component-charts"]');
      await box.scrollIntoViewIfNeeded();
      await box.screenshot({ path: join(outDir, 'dashboard-tracker-components.png') });
    });

    group = 'hexapod';
    await step('hexapod: upload DBB tests, calibrate from the panel, before/after table', async () => {
      const hexIds = [];
      for (const f of HEXAPOD_FIXTURES) {
        const r = await fetch(`${server.base}/api/v1/measurements`, {
          method: 'POST',
          body: readFileSync(join(fixtures, f)),
          headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': 'text/plain', 'X-Filename': f.split('/').pop() },
        });
        assert.equal(r.status, 201, `upload ${f}`);
        hexIds.push((await r.json()).id);
      }
      await page.click('#machines-refresh');
      await page.click(`#machines button[data-machine-id="${HEXAPOD_MACHINE}"]`);
      await page.waitForSelector(`#machines button[data-machine-id="${HEXAPOD_MACHINE}"][aria-current="true"]`);
      await page.waitForSelector('#calibration:not([hidden])');
      const choices = await page.$$eval('#calib-measurements input[data-testid="calib-choice"]', (bs) => bs.map((b) => Number(b.dataset.id)));
      assert.deepEqual(choices, [...hexIds].sort((a, b) => a - b));
      // Without a machine file the panel says so and submits nothing.
      await page.click('#calib-all');
      await page.click('#calib-run');
      await page.waitForSelector('#calib-status.error:has-text("machine definition")');
      await page.setInputFiles('#calib-machine-file', HEXAPOD_MACHINE_JSON);
      await page.selectOption('#calib-method', 'absolute');
      const t0 = Date.now();
      await page.click('#calib-run');
      // The job's page (#/jobs/{id}) follows it to the end; the server's verdict is ok.
      await page.waitForSelector('#job-view:not([hidden])[data-job-verdict="ok"]', { timeout: 60_000 });
      t.diagnostic(`calibration job took ${Date.now() - t0} ms`);
      const jobId = Number(await page.getAttribute('#job-view', 'data-job-id'));
      const job = await apiGet(server, `/api/v1/jobs/${jobId}`);
      assert.equal(job.status, 'done');
      assert.deepEqual(job.request.measurement_ids, [...hexIds].sort((a, b) => a - b));
      assert.equal(job.request.method, 'absolute');
      const res = job.result;
      const rows = await page.$$eval('[data-testid="calib-tests-table"] tbody tr', (trs) =>
        trs.map((tr) => Object.fromEntries([...tr.querySelectorAll('td')].map((td) => [td.dataset.key, td.textContent]))),
      );
      assert.equal(rows.length, res.tests.length);
      assert.equal(rows.length, HEXAPOD_FIXTURES.length);
      res.tests.forEach((tt, i) => {
        assert.equal(rows[i].test_id, tt.test_id);
        assert.equal(rows[i].direction, tt.direction.toUpperCase());
        assert.equal(rows[i].circularity_before_um, um3(tt.circularity_before_um), `before ${tt.test_id}`);
        assert.equal(rows[i].predicted_circularity_after_um, um3(tt.predicted_circularity_after_um), `after ${tt.test_id}`);
        for (const k of ['centre_deviation_before_um', 'centre_deviation_predicted_after_um',
                         'average_radial_error_before_um', 'average_radial_error_predicted_after_um']) {
          assert.equal(rows[i][k], um3(tt[k]), `${k} ${tt.test_id}`);
        }
      });
      // The simulated machine is off its nominal geometry: the correction must help.
      const meanOf = (k) => res.tests.reduce((s, tt) => s + tt[k], 0) / res.tests.length;
      assert.ok(meanOf('predicted_circularity_after_um') < 0.5 * meanOf('circularity_before_um'), 'predicted improvement');
      const params = await page.$$eval('[data-testid="calib-params-table"] td[data-param]', (tds) =>
        Object.fromEntries(tds.map((td) => [td.dataset.param, { text: td.textContent, fixed: td.classList.contains('fixed') }])),
      );
      assert.equal(Object.keys(params).length, 24);
      const fixedSet = new Set(res.fixed_parameters);
      for (let j = 0; j < 6; ++j) {
        const check = (name, v, u) => {
          const want = fixedSet.has(name) ? `${um3(v)} (fixed)` : `${um3(v)} ± ${unc2(u)}`;
          assert.equal(params[name].text, want, name);
          assert.equal(params[name].fixed, fixedSet.has(name), `${name} fixed mark`);
        };
        check(`strut_offset_um[${j}]`, res.parameters.strut_offset_um[j], res.parameter_uncertainty_um.strut_offset_um[j]);
        for (let c = 0; c < 3; ++c) {
          check(`base_joint_offset_um[${j}][${c}]`, res.parameters.base_joint_offset_um[j][c], res.parameter_uncertainty_um.base_joint_offset_um[j][c]);
        }
      }
      assert.equal(await page.textContent('[data-testid="calib-summary"] dd[data-key="residual_rms_um"]'), `${um3(res.residual_rms_um)} µm`);
      assert.equal(shown(await page.textContent('[data-testid="calib-summary"] dd[data-key="condition_number"]')).toFixed(3), res.condition_number.toFixed(3));
      await page.locator('#job-view').scrollIntoViewIfNeeded();
      await page.screenshot({ path: join(outDir, 'dashboard-hexapod.png') });
      const overflow = await page.evaluate(() => document.documentElement.scrollWidth);
      assert.ok(overflow <= 1280, `no horizontal scrolling (scrollWidth ${overflow})`);
      assert.deepEqual(pageErrors, []);
    });

    group = 'streams';
    await step('sensor streams: counts, gaps, downsampled envelope broken at the gap', async () => {
      const post = async (path, body, type) => {
        const r = await fetch(`${server.base}${path}`, {
          method: 'POST',
          headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': type },
          body,
        });
        const text = await r.text();
        assert.ok(r.ok, `${path}: HTTP ${r.status} ${text}`);
        return JSON.parse(text);
      };
      const stream = await post(
        '/api/v1/streams',
        JSON.stringify({ machine_id: MACHINE, name: 'browser stream', channels: [{ channel: 1 }, { channel: 2, name: 'probe Z', unit: 'µm' }] }),
        'application/json',
      );
      const t0 = 1763700000000000;
      const lines = [];
      for (const ch of [1, 2]) {
        for (let b = 0; b < 4000; b += 1000) {
          if (ch === 1 && b === 2000) continue; // a lost frame: a gap of 1000 samples
          const values = Array.from({ length: 1000 }, (_, k) => 0.2 * Math.sin((b + k) / 300) + 0.01 * ch);
          lines.push(JSON.stringify({ channel: ch, first_counter: b, t0_us: t0 + b * 100, dt_us: 100, values_um: values }));
        }
      }
      const ingest = await post(`/api/v1/streams/${stream.id}/frames`, `${lines.join('\n')}\n`, 'application/x-ndjson');
      assert.equal(ingest.stored, 7000);
      assert.equal(ingest.gaps.length, 1);
      await page.click('[data-testid="streams-refresh"]');
      const row = page.locator(`[data-testid="streams-table"] tr[data-stream="${stream.id}"]`);
      await row.waitFor();
      assert.equal((await row.locator('td[data-col="samples"]').textContent()).trim(), '7,000');
      assert.equal((await row.locator('td[data-col="gaps"]').textContent()).trim(), '1 (1,000 missing)');
      await row.locator('button.link').click();
      const svg = page.locator(`[data-testid="stream-svg"][data-stream="${stream.id}"]`);
      await svg.waitFor();
      const api1 = await apiGet(server, `/api/v1/streams/${stream.id}/samples?channel=1&max_points=600`);
      assert.equal(api1.downsampled, true);
      assert.equal(await svg.getAttribute('data-samples'), '3000');
      assert.equal(await svg.getAttribute('data-points'), String(api1.t_us.length));
      assert.equal(await svg.getAttribute('data-downsampled'), 'true');
      assert.equal(await svg.getAttribute('data-segments'), '2', 'the line is broken at the gap');
      assert.equal(await svg.locator('rect.gap').count(), 1);
      assert.equal(await svg.locator('rect.gap').getAttribute('data-missing'), '1000');
      assert.equal((await page.textContent('[data-testid="gaps-table"] td[data-col="missing"]')).trim(), '1,000');
      await page.selectOption('[data-testid="stream-channel"]', '2');
      await page.waitForFunction(
        () => document.querySelector('[data-testid="stream-svg"]')?.getAttribute('data-samples') === '4000',
      );
      assert.equal(await page.locator('[data-testid="stream-svg"]').getAttribute('data-segments'), '1');
      // The channel as declared when the stream was opened: its name and unit.
      assert.equal(await page.textContent('[data-testid="stream-channel"] option[value="2"]'), 'probe Z (channel 2)');
      assert.equal(await page.textContent('[data-testid="stream-svg"] [data-testid="stream-axis-title"]'), 'probe Z (µm)');
      assert.equal(await page.textContent('[data-testid="stream-channel"] option[value="1"]'), 'channel 1');
      // A straightness profile cut from the shown channel in the page (feed × time).
      await page.fill('[data-testid="profile-from"]', '0');
      await page.fill('[data-testid="profile-to"]', '0.39');
      await page.fill('[data-testid="profile-feed"]', '600');
      await page.click('[data-testid="profile-make"]');
      const made = await page.waitForSelector('[data-testid="profile-message"].success');
      const profileId = Number(await made.getAttribute('data-measurement-id'));
      const profile = await apiGet(server, `/api/v1/measurements/${profileId}`);
      assert.equal(profile.kind, 'straightness');
      assert.equal(String(profile.metadata.source_stream), String(stream.id));
      assert.equal(String(profile.metadata.source_channel), '2');
      const profileRes = await apiGet(server, `/api/v1/measurements/${profileId}/results`);
      assert.match(await made.textContent(), new RegExp(`#${profileId} — straightness ${profileRes.straightness_min_zone_um.toFixed(3)} µm`));
      assert.equal(await page.locator('[data-testid="stream-svg"] rect.gap').count(), 0);
      await page.locator('#streams-section').scrollIntoViewIfNeeded();
      await page.locator('#streams-section').screenshot({ path: join(outDir, 'dashboard-streams.png') });
      assert.deepEqual(pageErrors, []);
    });

    await step('Modbus device: live status from a real Modbus TCP server, its stream plotted', async () => {
      const bin = process.env.KM_MODBUS_TEST_SERVER;
      assert.ok(bin && existsSync(bin), `KM_MODBUS_TEST_SERVER (the libmodbus test server) is needed: '${bin}'`);
      const mb = spawn(bin, ['--port', '0'], { stdio: ['ignore', 'pipe', 'inherit'] });
      try {
        const mport = await new Promise((res, rej) => {
          let buf = '';
          mb.stdout.on('data', (d) => {
            buf += String(d);
            const m = /listening (\d+)/.exec(buf);
            if (m) res(Number(m[1]));
          });
          mb.on('exit', (code) => rej(new Error(`Modbus test server exited (${code})`)));
        });
        const device = {
          machine_id: MACHINE,
          name: 'browser-rig',
          host: '127.0.0.1',
          port: mport,
          poll_interval_ms: 20,
          channels: [{ channel: 1, name: 'uptime', address: 100, type: 'uint32', scale: 0.001 }],
        };
        const r = await fetch(`${server.base}/api/v1/devices`, {
          method: 'POST',
          headers: { Authorization: `Bearer ${server.token}`, 'Content-Type': 'application/json' },
          body: JSON.stringify(device),
        });
        const added = await r.json();
        assert.equal(r.status, 201, JSON.stringify(added));
        await page.check('[data-testid="streams-live"]');
        const row = page.locator('[data-testid="devices-table"] tr[data-device="browser-rig"]');
        await row.waitFor();
        await page.waitForFunction(() => {
          const tr = document.querySelector('[data-testid="devices-table"] tr[data-device="browser-rig"]');
          if (!tr) return false;
          const polls = Number(tr.querySelector('td[data-col="polls"]').textContent.replace(/,/g, ''));
          return tr.querySelector('td[data-col="state"]').textContent.trim() === 'connected' && polls >= 20;
        }, null, { timeout: 15_000 });
        const shownPolls = Number((await row.locator('td[data-col="polls"]').textContent()).replace(/,/g, ''));
        const api = (await apiGet(server, '/api/v1/devices')).items.find((d) => d.name === 'browser-rig');
        assert.ok(api.status.polls_ok >= shownPolls, `API polls ${api.status.polls_ok} ≥ shown ${shownPolls}`);
        assert.equal((await row.locator('td[data-col="exceptions"]').textContent()).trim(), '0');
        assert.equal(api.stream_id, added.stream_id);
        await row.locator('button').click();
        await page.waitForFunction(
          (id) => {
            const svg = document.querySelector(`[data-testid="stream-svg"][data-stream="${id}"]`);
            return Number(svg?.getAttribute('data-samples') || 0) > 0;
          },
          added.stream_id,
          { timeout: 10_000 },
        );
        assert.match(await page.textContent('#stream-title'), /modbus:browser-rig/);
        await page.locator('#streams-section').screenshot({ path: join(outDir, 'dashboard-devices.png') });
        await page.uncheck('[data-testid="streams-live"]');
        assert.deepEqual(pageErrors, []);
      } finally {
        mb.kill('SIGKILL');
      }
    });
    await step('every /api/ call carried the bearer token; no script errors', async () => {
      assert.ok(apiRequests.length >= 3, `API calls seen: ${apiRequests.length}`);
      for (const r of apiRequests) assert.equal(r.auth, `Bearer ${server.token}`, r.path);
      assert.deepEqual(pageErrors, []);
    }, ['*']);
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
