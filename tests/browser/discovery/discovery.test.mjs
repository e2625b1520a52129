// Browser test of the model-gap discovery page of the dashboard (web/static/discovery.js)
// against the real kinemetricd, driven by headless Chromium through playwright-core.
//
//   node tests/browser/discovery/discovery.test.mjs PATH/TO/kinemetricd PATH/TO/kinemetric [OUTPUT_DIR]
//
// Environment (optional): KINEMETRICD, KINEMETRIC_CLI (the binaries, if not given as arguments;
// the CLI defaults to `kinemetric` next to the server), KINEMETRIC_WEB_DIR, KINEMETRIC_WEB_ROOT,
// KINEMETRIC_BROWSER_OUT (screenshots), KINEMETRIC_CHROMIUM (default /usr/bin/chromium).
//
// The test simulates a hexapod with gravity deflection and joint friction (the CLI simulator,
// 15 tests × CW/CCW, two tool lengths, 180 samples a test), starts the server with a fresh data
// dir, uploads the 30 DBB files, stores the machine model tests/fixtures/pm600-like.json
// (POST /api/v1/machines → version 1), and then, from the page: starts a discovery of all 30
// tests against the stored model, follows the job, and checks the result against the job's
// result from the API — verdict banner, steps gravity_deflection then joint_friction with their
// evidence, p-values and held-out improvement, the bar chart of the gap (base, after each step,
// noise floor line), per-test gaps, the final model in words and human units, the compensation
// preview, the result JSON offered for download, and "Save as new machine model version" →
// version 2. Then: the address #/discoveries/{job_id} survives a reload, the sidebar lists the
// machine's discoveries, a serial study of the same tests (no model) and a failed job (tests in
// two planes) are shown for what they are, no console errors, no sideways scrolling at 1280 and
// 390 px. Screenshots go to the output dir. Missing prerequisites make the test FAIL.

// (session.mjs: the binaries, the server, the API calls.)

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { mkdirSync, mkdtempSync, readdirSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import {
  cliBin, outDir, chromiumPath, MACHINE_JSON, MACHINE, SERIAL_FIXTURE, SERIAL_MACHINE, SIM_ARGS,
  CHROMIUM_ARGS, loadPlaywright, checkPrerequisites, sleep, startServer, stopServer, api,
  apiGet, upload, um3, shown, INTERNAL_NAME,
} from './session.mjs';
import { sequentialSteps } from '../lib/harness.mjs';

// ------------------------------------------------------------------ the test

test('discovery page: hexapod gravity + friction found step by step, saved as version 2', { timeout: 220_000 }, async (t) => {
  checkPrerequisites();
  const { chromium } = loadPlaywright();
  mkdirSync(outDir, { recursive: true });

  let server = null;
  let browser = null;
  let page = null;
  const simDir = mkdtempSync(join(tmpdir(), 'kinemetric-discovery-sim-'));
  const killOnExit = () => server?.child.kill('SIGKILL');
  process.once('exit', killOnExit);
  const { step, failed } = sequentialSteps(t);

  try {
    // The simulated tests first: the server is then busy from its start.
    execFileSync(cliBin, [...SIM_ARGS, '--out', simDir], { stdio: ['ignore', 'pipe', 'pipe'] });
    server = await startServer();
    browser = await chromium.launch({ executablePath: chromiumPath, args: CHROMIUM_ARGS });
    const context = await browser.newContext({ viewport: { width: 1280, height: 900 }, acceptDownloads: true });
    page = await context.newPage();
    page.setDefaultTimeout(15_000);
    const pageErrors = [];
    page.on('pageerror', (err) => pageErrors.push(String(err)));
    page.on('console', (msg) => {
      // 4xx answers to fetch() are logged by Chromium as "Failed to load resource"; expected.
      if (msg.type() === 'error' && !/Failed to load resource/.test(msg.text())) pageErrors.push(msg.text());
    });

    const ids = [];
    let jobId = null;
    let job = null;

    await step('simulate the hexapod tests, upload them, store the machine model (version 1)', async () => {
      const files = readdirSync(simDir).filter((f) => f.endsWith('.txt')).sort();
      assert.equal(files.length, 30, `15 tests × CW/CCW: ${files.join(' ')}`);
      for (const f of files) ids.push(await upload(server, f, readFileSync(join(simDir, f))));
      const stored = await api(server, 'POST', '/api/v1/machines', readFileSync(MACHINE_JSON), { 'Content-Type': 'application/json', 'X-Filename': 'pm600-like.json' });
      assert.equal(stored.status, 201, stored.text);
      assert.equal(stored.json.machine_id, MACHINE);
      assert.equal(stored.json.version, 1);
    });

    await step('start a discovery from the page: stored model, all DBB tests', async () => {
      await page.goto(`${server.base}/#token=${encodeURIComponent(server.token)}`);
      await page.waitForSelector('body[data-ready="true"]');
      await page.click(`#machines button[data-machine-id="${MACHINE}"]`);
      await page.waitForSelector(`#machines button[data-machine-id="${MACHINE}"][aria-current="true"]`);
      await page.waitForSelector('[data-testid="discoveries-panel"]:not([hidden])');
      // The panel shows before its list is filled: wait for the list's own answer.
      await page.waitForFunction(() => /No discovery of this machine yet/.test(document.querySelector('#discoveries').textContent));
      await page.click('[data-testid="discovery-new-link"]');
      await page.waitForFunction(() => window.location.hash === '#/discoveries?machine=pm600-like');
      await page.waitForSelector('#discovery:not([hidden]) [data-testid="disc-form"]');
      assert.equal(await page.isHidden('#detail'), true, 'the measurement view gives way to the discovery page');
      // All DBB tests of the machine are offered and ticked.
      await page.waitForFunction((n) => document.querySelectorAll('[data-testid="disc-choice"]').length === n, ids.length);
      const choices = await page.$$eval('[data-testid="disc-choice"]', (bs) => bs.map((b) => ({ id: Number(b.dataset.id), on: b.checked })));
      assert.deepEqual(choices.map((c) => c.id), [...ids].sort((a, b) => a - b));
      assert.ok(choices.every((c) => c.on), 'every test ticked by default');
      // The stored model is offered (and chosen: it is this machine's), with its versions.
      await page.waitForFunction(() => document.querySelector('#disc-model').value === 'pm600-like');
      await page.waitForSelector('#disc-version option[value="1"]', { state: 'attached' });
      const models = await page.$$eval('#disc-model option', (os) => os.map((o) => o.value));
      assert.deepEqual(models, ['', MACHINE], 'none (serial) or the stored model');
      // Nothing ticked: the page says so and submits nothing.
      await page.click('#disc-none');
      await page.click('#disc-run');
      await page.waitForSelector('#disc-form-status.error:has-text("No measurement chosen")');
      await page.click('#disc-all');
      assert.equal(await page.textContent('#disc-count'), `${ids.length} of ${ids.length} chosen`);
      await page.click('#disc-run');
      await page.waitForFunction(() => /^#\/discoveries\/\d+$/.test(window.location.hash));
      jobId = Number((await page.evaluate(() => window.location.hash)).split('/').pop());
      const j = await apiGet(server, `/api/v1/jobs/${jobId}`);
      assert.equal(j.kind, 'discovery');
      assert.equal(j.request.machine_id, MACHINE);
      assert.equal(j.request.machine_version, 1, 'the server records the version used');
      assert.deepEqual([...j.request.measurement_ids].sort((a, b) => a - b), [...ids].sort((a, b) => a - b));
    });

    await step('job progress: step and candidate being tried, then the result', async () => {
      // Sample what the page shows while the job runs.
      const seen = [];
      const t0 = Date.now();
      for (;;) {
        const s = await page.evaluate(() => {
          const st = document.querySelector('#disc-status');
          return {
            status: st.dataset.status || '',
            stage: document.querySelector('[data-testid="disc-stage"]')?.textContent || '',
            step: document.querySelector('[data-testid="disc-step"]')?.dataset.step || '',
            progress: document.querySelector('[data-testid="disc-progress"]')?.getAttribute('value') || '',
            verdict: Boolean(document.querySelector('[data-testid="disc-verdict"]')),
          };
        });
        if (s.stage) seen.push(s);
        if (s.verdict) break;
        assert.ok(Date.now() - t0 < 150_000, 'discovery finished within 150 s');
        await sleep(100);
      }
      t.diagnostic(`discovery job took ${Date.now() - t0} ms; stages seen: ${JSON.stringify([...new Set(seen.map((s) => `${s.step}|${s.stage}`))])}`);
      job = await apiGet(server, `/api/v1/jobs/${jobId}`);
      assert.equal(job.status, 'done', job.error);
      assert.ok(seen.length > 0, 'the job was seen running');
      // The engine reports "trying EFFECT (variant)" for each candidate it scores and "adding
      // EFFECT" while it refits with the chosen one; scoring is quick, so at the page's polling
      // rate mostly the latter is seen. Either names the step and the effect, in words.
      const working = seen.filter((s) => /^(trying|adding) /.test(s.stage));
      assert.ok(working.length > 0, `a step and its candidate were shown: ${JSON.stringify(seen.slice(0, 8))}`);
      for (const s of working) {
        assert.ok(!INTERNAL_NAME.test(s.stage), `stage in words: ${s.stage}`);
        assert.ok(Number(s.step) >= 1, `step shown with the candidate: ${JSON.stringify(s)}`);
      }
      const added = [...new Set(working.filter((s) => /^adding /.test(s.stage)).map((s) => `${s.step}|${s.stage}`))];
      for (const a of added) assert.match(a, /^1\|adding gravity deflection$|^2\|adding joint friction$/);
    });

    await step('verdict banner and summary follow the job result', async () => {
      const r = job.result;
      assert.equal(r.kind, 'hexapod');
      assert.equal(r.verdict, 'complete', `the simulated set is explained: ${r.stop_reason}`);
      const banner = await page.$eval('[data-testid="disc-verdict"]', (b) => ({ verdict: b.dataset.verdict, cls: b.className, text: b.textContent }));
      assert.equal(banner.verdict, 'complete');
      assert.match(banner.cls, /verdict-complete/);
      assert.match(banner.text, /^Complete/);
      assert.ok(banner.text.includes(r.stop_reason), `stop reason shown: ${banner.text}`);
      assert.ok(banner.text.includes(`${um3(r.unexplained_rms_um)} µm`), 'unexplained gap shown');
      assert.ok(banner.text.includes(`${um3(r.noise_floor_um)} µm`), 'noise floor shown');
    });

    await step('step table: gravity deflection, then joint friction, with the evidence', async () => {
      const r = job.result;
      assert.deepEqual(r.steps.map((s) => s.added_effect), ['gravity_deflection', 'joint_friction'], 'the hidden effects, in order of size');
      const rows = await page.$$eval('[data-testid="disc-steps"] tbody tr', (trs) =>
        trs.map((tr) => ({
          step: tr.dataset.step,
          effect: tr.dataset.effect,
          label: tr.querySelector('[data-key="effect"]').textContent,
          before: tr.querySelector('[data-key="gap_rms_before_um"]').textContent,
          after: tr.querySelector('[data-key="gap_rms_after_um"]').textContent,
          sentence: tr.querySelector('[data-key="sentence"]').textContent,
          log10p: tr.querySelector('[data-key="p_value"]').dataset.log10P,
          p: tr.querySelector('[data-key="p_value"]').textContent,
          heldOut: Number(tr.querySelector('[data-key="held_out"]').dataset.pct),
          heldOutText: tr.querySelector('[data-key="held_out"]').textContent,
        })),
      );
      assert.deepEqual(rows.map((x) => x.effect), ['gravity_deflection', 'joint_friction']);
      assert.match(rows[0].label, /^Gravity deflection/);
      // The form taken: a ramp length of the candidate grid, t1 held or fitted, in words.
      assert.match(rows[1].label, /^Joint friction \(ramp length [\d.]+ mm(, load-dependent torque fitted)?\)$/);
      rows.forEach((row, i) => {
        const s = r.steps[i];
        const ev = s.evidence;
        assert.equal(row.step, String(i + 1));
        assert.equal(row.before, um3(s.gap_rms_before_um), `step ${i + 1} gap before`);
        assert.equal(row.after, um3(s.gap_rms_after_um), `step ${i + 1} gap after`);
        assert.ok(!INTERNAL_NAME.test(row.sentence), `sentence in words: ${row.sentence}`);
        assert.ok(row.sentence.startsWith(ev.sentence.slice(0, 40)), `the evidence sentence: ${row.sentence}`);
        assert.equal(Number(row.log10p), ev.log10_p_value);
        // p underflows to 0: shown as a power of ten from its log10, or as "< 10⁻¹⁵" below that
        // (no more digits than a double carries).
        const pText = ev.log10_p_value < -15 ? '< 10−15' : `${(10 ** (ev.log10_p_value - Math.floor(ev.log10_p_value))).toFixed(1)} × 10${`${Math.floor(ev.log10_p_value)}`.replace('-', '−')}`;
        assert.equal(row.p, pText);
        const ho = 100 * (1 - ev.cv_press_after_um2 / ev.cv_press_before_um2);
        assert.ok(Math.abs(row.heldOut - ho) < 1e-9, `held-out improvement ${row.heldOut} vs ${ho}`);
        assert.ok(ho > 50, 'each step predicts held-out tests much better');
        assert.ok(row.heldOutText.startsWith(`−${ho.toFixed(1)} %`), row.heldOutText);
      });
    });

    await step('bar chart: base gap, then after each step, noise floor line', async () => {
      const r = job.result;
      const chart = await page.$eval('[data-testid="disc-gap-chart"]', (svg) => ({
        pxPerUm: Number(svg.dataset.pxPerUm),
        zero: Number(svg.dataset.zeroPx),
        noise: Number(svg.dataset.noiseFloorUm),
        bars: [...svg.querySelectorAll('g.bar')].map((g) => ({
          step: Number(g.dataset.step),
          effect: g.dataset.effect,
          gap: Number(g.dataset.gapUm),
          width: Number(g.querySelector('rect').getAttribute('width')),
          label: svg.querySelector(`.bar-label[data-step="${g.dataset.step}"]`).textContent,
          value: svg.querySelector(`.bar-value[data-step="${g.dataset.step}"]`).textContent,
        })),
        line: (() => {
          const l = svg.querySelector('[data-testid="disc-noise-floor"]');
          return l && { x: Number(l.getAttribute('x1')), um: Number(l.dataset.um) };
        })(),
      }));
      const want = [r.base.gap_rms_um, ...r.steps.map((s) => s.gap_rms_after_um)];
      assert.deepEqual(chart.bars.map((b) => b.step), [0, 1, 2]);
      assert.deepEqual(chart.bars.map((b) => b.effect), ['', 'gravity_deflection', 'joint_friction']);
      assert.match(chart.bars[1].label, /Gravity deflection/);
      assert.match(chart.bars[2].label, /Joint friction/);
      chart.bars.forEach((b, i) => {
        assert.equal(b.gap, want[i], `bar ${i}`);
        assert.equal(b.value, `${want[i].toFixed(3)} µm`, `bar ${i} value label`);
        assert.ok(Math.abs(b.width - want[i] * chart.pxPerUm) < 0.011, `bar ${i} length ${b.width} for ${want[i]} µm`);
      });
      assert.ok(chart.bars[0].width > chart.bars[1].width && chart.bars[1].width > chart.bars[2].width, 'the gap shrinks step by step');
      assert.equal(chart.noise, r.noise_floor_um);
      assert.ok(chart.line, 'noise floor line drawn');
      assert.equal(chart.line.um, r.noise_floor_um);
      assert.ok(Math.abs(chart.line.x - (chart.zero + r.noise_floor_um * chart.pxPerUm)) < 0.011, 'noise floor line at its value');
      const box = await page.$('[data-testid="disc-gap-chart"]');
      await box.screenshot({ path: join(outDir, 'discovery-gap-chart.png') });
    });

    await step('per-test gaps at each step (collapsible)', async () => {
      const r = job.result;
      const details = page.locator('[data-testid="disc-test-gaps"]');
      assert.equal(await details.evaluate((d) => d.open), false, 'collapsed at first');
      await details.locator('summary').click();
      const rows = await page.$$eval('[data-testid="disc-test-gaps"] tbody tr', (trs) =>
        trs.map((tr) => ({ test: tr.dataset.testId, dir: tr.dataset.direction, cells: [...tr.querySelectorAll('td[data-step]')].map((td) => td.textContent) })),
      );
      assert.equal(rows.length, r.base.tests.length);
      rows.forEach((row, i) => {
        const b = r.base.tests[i];
        assert.equal(row.test, b.test_id);
        assert.equal(row.dir, b.direction);
        assert.deepEqual(row.cells, [um3(b.gap_rms_before_um), ...r.steps.map((s) => um3(s.tests[i].gap_rms_after_um))], `test ${b.test_id} ${b.direction}`);
      });
    });

    await step('final model: parameters ± uncertainty in words and human units', async () => {
      const r = job.result;
      const box = page.locator('[data-testid="disc-final-model"]');
      const text = await box.innerText();
      assert.ok(!INTERNAL_NAME.test(text), `no internal names in the final model: ${text.match(INTERNAL_NAME)}`);
      const rows = await page.$$eval('[data-testid="disc-effects"] tbody tr', (trs) =>
        trs.map((tr) => ({ effect: tr.dataset.effect, param: tr.dataset.param, value: tr.querySelector('[data-key="value"]').textContent, unit: tr.querySelector('.unit').textContent, text: tr.textContent })),
      );
      const gravity = r.final_model.find((e) => e.effect === 'gravity_deflection');
      const friction = r.final_model.find((e) => e.effect === 'joint_friction');
      const g = rows.find((x) => x.param === 'K_stiff2_mm_per_N');
      assert.equal(g.unit, 'µm/kN');
      const [gv, gs] = g.value.split(' ± ').map(shown);
      assert.ok(Math.abs(gv - 1e6 * gravity.parameters.K_stiff2_mm_per_N) <= 1e6 * gravity.uncertainty.K_stiff2_mm_per_N, `K2 ${g.value}`);
      assert.ok(Math.abs(gs - 1e6 * gravity.uncertainty.K_stiff2_mm_per_N) / (1e6 * gravity.uncertainty.K_stiff2_mm_per_N) < 0.05, `σ K2 ${g.value}`);
      // The simulated truth: 1.52e-5 mm/N = 15.2 µm/kN, 8.88 N·m.
      assert.ok(Math.abs(gv - 15.2) < 0.3, `compliance found ${gv} µm/kN`);
      const torque = rows.find((x) => x.param === 'torque_Nm');
      assert.equal(torque.unit, 'N·m');
      const [tv, ts] = torque.value.split(' ± ').map(shown);
      assert.ok(Math.abs(tv - friction.parameters.torque_Nm) <= friction.uncertainty.torque_Nm, `torque ${torque.value}`);
      assert.ok(ts > 0);
      assert.ok(Math.abs(tv - 8.88) < 0.3, `friction torque found ${tv} N·m`);
      assert.match(torque.text, /Base-joint friction torque/);
      for (const name of friction.fixed_parameters || []) {
        const fx = rows.find((x) => x.param === name);
        assert.match(fx.value, /held at the machine file's value/, `${name} fixed`);
      }
      // Kinematic parameters: 6 struts × (length, base joint X/Y/Z), µm ± σ.
      const kin = r.final_model.find((e) => e.effect === 'kinematic_parameters');
      const cells = await page.$$eval('[data-testid="disc-kinematic"] td[data-param]', (tds) => Object.fromEntries(tds.map((td) => [td.dataset.param, td.textContent])));
      assert.equal(Object.keys(cells).length, 24);
      for (let j = 0; j < 6; ++j) {
        assert.equal(cells[`strut_offset_um[${j}]`], `${um3(kin.parameters.strut_offset_um[j])} ± ${um3(kin.uncertainty.strut_offset_um[j])}`);
        for (let c = 0; c < 3; ++c) {
          assert.equal(cells[`base_joint_offset_um[${j}][${c}]`], `${um3(kin.parameters.base_joint_offset_um[j][c])} ± ${um3(kin.uncertainty.base_joint_offset_um[j][c])}`);
        }
      }
    });

    await step('compensation preview table (as [PM-600 report] table 4.5)', async () => {
      const c = job.result.compensation;
      assert.ok(c && c.tests.length === 30, 'the job previews the compensation');
      const rows = await page.$$eval('[data-testid="disc-compensation"] tbody tr', (trs) =>
        trs.map((tr) => ({
          test: tr.dataset.testId,
          dir: tr.dataset.direction,
          without: tr.querySelector('[data-key="circularity_without_compensation_um"]').textContent,
          with: tr.querySelector('[data-key="predicted_circularity_with_compensation_um"]').textContent,
        })),
      );
      assert.equal(rows.length, c.tests.length);
      rows.forEach((row, i) => {
        assert.equal(row.test, c.tests[i].test_id);
        assert.equal(row.dir, c.tests[i].direction);
        assert.equal(row.without, um3(c.tests[i].circularity_without_compensation_um));
        assert.equal(row.with, um3(c.tests[i].predicted_circularity_with_compensation_um));
      });
      assert.match(await page.textContent('[data-testid="disc-compensation"]'), /gravity deflection and joint friction/);
    });

    await step('result JSON download is the job result', async () => {
      const link = page.locator('[data-testid="disc-download"]');
      assert.equal(await link.getAttribute('download'), `kinemetric-discovery-job-${jobId}.json`);
      // (The page's CSP allows no fetch of blob: URLs; the download itself is read instead.)
      const [download] = await Promise.all([page.waitForEvent('download'), link.click()]);
      assert.equal(download.suggestedFilename(), `kinemetric-discovery-job-${jobId}.json`);
      const body = readFileSync(await download.path(), 'utf8');
      assert.deepEqual(JSON.parse(body), job.result);
      assert.deepEqual(pageErrors, []);
    });

    await step('"Save as new machine model version" stores version 2', async () => {
      await page.click('[data-testid="disc-save"]');
      const status = page.locator('[data-testid="disc-save-status"][data-version]');
      await status.waitFor();
      assert.equal(await status.getAttribute('data-version'), '2');
      assert.match(await status.textContent(), /Saved as pm600-like version 2/);
      const defs = await apiGet(server, `/api/v1/machines/${MACHINE}/definitions`);
      assert.deepEqual(defs.versions.map((v) => v.version), [1, 2]);
      assert.equal(defs.versions[1].source, `discovery job ${jobId}`);
      const doc = await api(server, 'GET', `/api/v1/machines/${MACHINE}/definition?version=2`);
      assert.equal(doc.status, 200);
      assert.deepEqual(JSON.parse(doc.text), job.result.updated_machine, 'version 2 is the machine the job produced');
      // The sidebar's machine list now counts two model versions.
      const machines = await apiGet(server, '/api/v1/machines');
      assert.equal(machines.machines.find((m) => m.machine_id === MACHINE).model_versions, 2);
      await page.locator('[data-testid="discovery-view"]').screenshot({ path: join(outDir, 'discovery-1280.png') });
      const width = await page.evaluate(() => document.documentElement.scrollWidth);
      assert.ok(width <= 1280, `no sideways scrolling at 1280 px (scrollWidth ${width})`);
    });

    await step('the address keeps the page over a reload; the sidebar lists the discovery', async () => {
      await page.reload();
      await page.waitForSelector('body[data-ready="true"]');
      assert.equal(await page.evaluate(() => window.location.hash), `#/discoveries/${jobId}`);
      await page.waitForSelector('[data-testid="disc-verdict"][data-verdict="complete"]');
      await page.waitForSelector(`#machines button[data-machine-id="${MACHINE}"][aria-current="true"]`);
      const item = page.locator(`[data-testid="discovery-item"][data-job-id="${jobId}"]`);
      await item.waitFor();
      assert.equal(await item.getAttribute('aria-current'), 'page');
      assert.equal(await item.getAttribute('data-status'), 'done');
      assert.match(await item.textContent(), /model pm600-like v1 · 30 tests/);
      // Back to the measurements and into the job again through the list.
      await page.click('[data-testid="discovery-close"]');
      await page.waitForSelector('#detail:not([hidden])');
      assert.equal(await page.isHidden('#discovery'), true);
      await item.click();
      await page.waitForSelector('#discovery:not([hidden]) [data-testid="disc-verdict"][data-verdict="complete"]');
      // The job's general address #/jobs/{id} leads to the discovery page; the view carries the
      // job and the server's verdict on it (a complete discovery is "ok").
      const job = await apiGet(server, `/api/v1/jobs/${jobId}`);
      assert.equal(job.verdict, 'ok');
      assert.deepEqual(job.verdict_reasons, []);
      await page.evaluate((id) => {
        window.location.hash = `#/jobs/${id}`;
      }, jobId);
      await page.waitForFunction((id) => window.location.hash === `#/discoveries/${id}`, jobId);
      await page.waitForSelector(`#discovery:not([hidden])[data-job-id="${jobId}"][data-job-verdict="ok"]`);
      // A new discovery starts from the newest version, the one just saved.
      await page.click('[data-testid="discovery-new-link"]');
      await page.waitForSelector('#disc-version option[value="2"]', { state: 'attached' });
      assert.match(await page.textContent('#disc-version option[value=""]'), /newest \(version 2\)/);
    });

    await step('serial study of the same tests (no model): verdict as the job says, nothing to save', async () => {
      await page.selectOption('#disc-model', '');
      assert.equal(await page.isDisabled('#disc-version'), true);
      await page.click('#disc-none');
      // Test a, CCW and CW (the list is drawn again once the tests' planes are read).
      await page.waitForFunction(() => [...document.querySelectorAll('#disc-measurements label')]
        .filter((l) => /^a(CCW|CW)/.test(l.textContent.replace(/\s+/g, ''))).length === 2);
      const two = await page.$$eval('#disc-measurements label', (ls) =>
        ls.filter((l) => /^a(CCW|CW)/.test(l.textContent.replace(/\s+/g, ''))).map((l) => Number(l.querySelector('input').dataset.id)),
      );
      assert.equal(two.length, 2);
      for (const id of two) await page.check(`[data-testid="disc-choice"][data-id="${id}"]`);
      await page.click('#disc-run');
      await page.waitForFunction((prev) => /^#\/discoveries\/\d+$/.test(window.location.hash) && window.location.hash !== `#/discoveries/${prev}`, jobId);
      const serialId = Number((await page.evaluate(() => window.location.hash)).split('/').pop());
      await page.waitForSelector('[data-testid="disc-verdict"]', { timeout: 60_000 });
      const sj = await apiGet(server, `/api/v1/jobs/${serialId}`);
      assert.equal(sj.status, 'done', sj.error);
      assert.equal(sj.result.kind, 'serial');
      assert.equal(sj.request.machine_id, undefined);
      const banner = await page.$eval('[data-testid="disc-verdict"]', (b) => ({ verdict: b.dataset.verdict, cls: b.className, text: b.textContent }));
      assert.equal(banner.verdict, sj.result.verdict);
      if (sj.result.verdict === 'complete') {
        assert.match(banner.cls, /verdict-complete/);
      } else {
        assert.match(banner.cls, /verdict-misfit|verdict-unclear/);
        assert.doesNotMatch(banner.cls, /verdict-complete/);
        assert.ok(banner.text.includes(sj.result.stop_reason), 'stop reason in the misfit banner');
      }
      const effects = await page.$$eval('[data-testid="disc-steps"] tbody tr[data-effect]', (trs) => trs.map((tr) => tr.dataset.effect));
      assert.deepEqual(effects, sj.result.steps.map((s) => s.added_effect));
      assert.equal(await page.locator('[data-testid="disc-save"]').count(), 0, 'a serial study has no machine to save');
      assert.match(await page.textContent('[data-testid="disc-actions"]'), /serial study produces no machine model/);
      const finalText = await page.locator('[data-testid="disc-final-model"]').innerText();
      assert.ok(!INTERNAL_NAME.test(finalText), `serial final model in words: ${finalText.match(INTERNAL_NAME)}`);
      assert.deepEqual(pageErrors, []);
    });

    await step('a failed job: red banner with the reason, no figures', async () => {
      // Two tests of one machine in two planes: the serial study refuses them when it runs.
      const xy = readFileSync(SERIAL_FIXTURE, 'utf8');
      const xz = xy.replace('# test_id: xy-r150', '# test_id: zx-r150\n# plane: ZX');
      assert.notEqual(xz, xy);
      const a = await upload(server, 'dbb_xy-r150_ccw.txt', Buffer.from(xy));
      const b = await upload(server, 'dbb_zx-r150_ccw.txt', Buffer.from(xz));
      const sub = await api(server, 'POST', '/api/v1/discoveries', JSON.stringify({ measurement_ids: [a, b] }), { 'Content-Type': 'application/json' });
      assert.equal(sub.status, 202, sub.text);
      const failedId = sub.json.job_id;
      await page.evaluate((id) => {
        window.location.hash = `#/discoveries/${id}`;
      }, failedId);
      await page.waitForSelector('[data-testid="disc-verdict"][data-verdict="failed"]', { timeout: 60_000 });
      const fj = await apiGet(server, `/api/v1/jobs/${failedId}`);
      assert.equal(fj.status, 'failed');
      const banner = await page.$eval('[data-testid="disc-verdict"]', (x) => ({ cls: x.className, text: x.textContent }));
      assert.match(banner.cls, /verdict-failed/);
      assert.ok(banner.text.includes(fj.error), `the reason: ${banner.text}`);
      for (const sel of ['disc-gap-chart', 'disc-steps', 'disc-final-model', 'disc-compensation', 'disc-save', 'disc-download']) {
        assert.equal(await page.locator(`[data-testid="${sel}"]`).count(), 0, `no ${sel} for a failed job`);
      }
      // The sidebar follows the failed job's machine and lists it there.
      await page.waitForSelector(`#machines button[data-machine-id="${SERIAL_MACHINE}"][aria-current="true"]`);
      await page.waitForSelector(`[data-testid="discovery-item"][data-job-id="${failedId}"][data-status="failed"]`);
      await page.locator('[data-testid="discovery-view"]').screenshot({ path: join(outDir, 'discovery-failed.png') });
    });

    await step('390 px wide: the result page fits without sideways scrolling', async () => {
      await page.setViewportSize({ width: 390, height: 844 });
      await page.evaluate((id) => {
        window.location.hash = `#/discoveries/${id}`;
      }, jobId);
      await page.waitForSelector('[data-testid="disc-verdict"][data-verdict="complete"]');
      await page.waitForSelector('[data-testid="disc-gap-chart"]');
      const width = await page.evaluate(() => document.documentElement.scrollWidth);
      assert.ok(width <= 390, `no sideways scrolling at 390 px (scrollWidth ${width})`);
      const chartWidth = await page.$eval('[data-testid="disc-gap-chart"]', (svg) => svg.getBoundingClientRect().width);
      assert.ok(chartWidth > 250 && chartWidth <= 390, `chart scales to the screen (${chartWidth} px)`);
      // The page is brought into view below the stacked sidebar.
      const top = await page.$eval('#discovery', (x) => x.getBoundingClientRect().top);
      assert.ok(Math.abs(top) < 5, `the discovery page is scrolled into view (top at ${top} px)`);
      await page.screenshot({ path: join(outDir, 'discovery-390-screen.png') });
      await page.locator('[data-testid="discovery-view"]').screenshot({ path: join(outDir, 'discovery-390.png') });
      assert.deepEqual(pageErrors, []);
    });
  } finally {
    if (failed() && page) {
      const shot = join(outDir, 'discovery-failure.png');
      await page.screenshot({ path: shot, fullPage: true }).then(() => console.error(`failure screenshot: ${shot}`), () => {});
    }
    if (browser) await browser.close().catch(() => {});
    if (failed() && server) console.error(`kinemetricd log (tail):\n${server.log()}`);
    await stopServer(server);
    rmSync(simDir, { recursive: true, force: true });
    process.removeListener('exit', killOnExit);
  }
});
