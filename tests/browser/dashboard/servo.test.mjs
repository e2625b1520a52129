// Browser scenario: a maintenance engineer uploads the servo loads logged during a routine DBB
// cycle (CW and CCW circles of the jig plan, simulated by km_servo_sim — the independent
// simulator of the servo tests — with leg 4's joint resistance 3× the others') and learns which
// joint is getting stiff. On the machine's page the joint-health panel, after "Estimate", names
// leg 4 at level 3 and every other leg at level 1 (colour and words), draws the level-2 and
// level-3 limits of each leg and the history (one line a leg, the limits drawn); the same
// estimate asked for again is kept once. A servo record's page draws each strut's force,
// measured and modelled, exactly as GET …/servo/force answers.
//   node tests/browser/dashboard/servo.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]
// Environment: KM_SERVO_SIM, the km_servo_sim binary (tests/unit/servo).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { existsSync, mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { assertNoHorizontalOverflow, outDir, repo, withDashboard } from '../lib/harness.mjs';

const MACHINE = 'pm600-like';
const STIFF_LEG = 4;
const SAMPLES = 240;

function simulate() {
  const sim = process.env.KM_SERVO_SIM || '';
  assert.ok(sim && existsSync(sim), `KM_SERVO_SIM (${sim || 'unset'}) must name the km_servo_sim binary (build target km_servo_sim)`);
  const dir = mkdtempSync(join(tmpdir(), 'kinemetric-servo-'));
  const names = execFileSync(sim, [dir, '--samples', String(SAMPLES), '--stiff-leg', String(STIFF_LEG), '--factor', '3'], { encoding: 'utf8' }).trim().split('\n');
  const files = names.map((name) => ({ name, text: readFileSync(join(dir, name), 'utf8') }));
  rmSync(dir, { recursive: true, force: true });
  return files;
}

test('joint health names the stiff leg; strut forces measured and modelled', { timeout: 110_000 }, async () => {
  const files = simulate();
  assert.equal(files.length, 30, 'the jig plan: 15 CW/CCW pairs');
  await withDashboard('servo', async ({ api, page, open }) => {
    const machine = readFileSync(join(repo, 'data/machines/pm600-like.json'), 'utf8');
    await api.post('/api/v1/machines', machine);
    const ids = [];
    for (const f of files) ids.push((await api.upload(f.text, f.name)).id);

    await open(`#/machines/${MACHINE}`);
    await page.waitForSelector('#joint-health:not([hidden])[data-estimates="0"]');
    await page.click('#joint-estimate');
    await page.waitForSelector('#joint-health[data-level="3"]', { timeout: 60_000 });

    const history = await api.get(`/api/v1/machines/${MACHINE}/joint-health`);
    assert.equal(history.estimates.length, 1);
    const est = history.estimates[0];
    assert.deepEqual([...est.measurement_ids].sort((a, b) => a - b), ids, 'every record of the cycle used');
    assert.deepEqual(est.legs.map((g) => g.level), [1, 2, 3, 4, 5, 6].map((k) => (k === STIFF_LEG ? 3 : 1)), JSON.stringify(est.legs.map((g) => g.evidence)));
    // Recover the truth: leg 4 is 3× its reference (the machine model's), the others 1× (±15 %).
    est.legs.forEach((g) => {
      const want = g.leg === STIFF_LEG ? 3 : 1;
      assert.ok(Math.abs(g.ratio - want) < 0.15 * want, `leg ${g.leg}: ratio ${g.ratio}, expected ${want}`);
    });

    // The bars: level in colour (class) and words, one per leg, limits of each leg drawn.
    const bars = await page.$$eval('[data-testid="joint-bar"]', (gs) =>
      gs.map((g) => ({ leg: Number(g.dataset.leg), level: Number(g.dataset.level), cls: g.getAttribute('class'), fill: getComputedStyle(g.querySelector('.bar-fill')).fill, r: Number(g.dataset.resistanceNm) })),
    );
    assert.equal(bars.length, 6);
    bars.forEach((b, k) => {
      assert.equal(b.level, est.legs[k].level, `bar of leg ${b.leg}`);
      assert.equal(b.r, est.legs[k].resistance_Nm);
      assert.match(b.cls, new RegExp(`level-${b.level}`));
    });
    assert.notEqual(bars[STIFF_LEG - 1].fill, bars[0].fill, 'level 3 and level 1 bars differ in colour');
    for (const cls of ['level2', 'level3']) {
      const drawn = await page.$$eval(`[data-testid="joint-bars"] [data-testid="limit-${cls}"]`, (ls) => ls.map((l) => Number(l.dataset.valueNm)));
      const ratio = history.limits[`${cls}_ratio`];
      assert.deepEqual(drawn, history.limits.reference_Nm.map((r) => ratio * r), `${cls} limits of the six legs`);
    }
    const words = await page.$$eval('[data-testid="joint-leg"]', (rows) => rows.map((r) => [Number(r.dataset.leg), r.querySelector('[data-testid="joint-level"]').textContent]));
    assert.deepEqual(words, [1, 2, 3, 4, 5, 6].map((k) => [k, k === STIFF_LEG ? 'level 3 — stop' : 'level 1 — normal']));
    const summary = await page.textContent('[data-testid="joint-summary"]');
    assert.match(summary, /level 3 — stop: leg 4 \(/);
    // The history: one line a leg, the two limits drawn.
    assert.equal(await page.getAttribute('[data-testid="joint-history-chart"]', 'data-estimates'), '1');
    assert.equal(await page.locator('[data-testid="history-leg"]').count(), 6);
    assert.equal(await page.getAttribute('[data-testid="history-limit-level2"]', 'data-ratio'), String(history.limits.level2_ratio));
    assert.equal(await page.getAttribute('[data-testid="history-limit-level3"]', 'data-ratio'), String(history.limits.level3_ratio));
    await page.locator('#joint-health').screenshot({ path: join(outDir, 'servo-joint-health.png') });

    // The same estimate again is kept once; the record's own result is unchanged.
    await page.click('#joint-estimate');
    await page.waitForSelector('#joint-status.success');
    assert.equal((await api.get(`/api/v1/machines/${MACHINE}/joint-health`)).estimates.length, 1);
    assert.equal((await api.get(`/api/v1/measurements/${ids[0]}/results`)).record, 'hexapod');
    await page.setViewportSize({ width: 400, height: 800 });
    await assertNoHorizontalOverflow(page, '400 px, joint health');
    await page.setViewportSize({ width: 1280, height: 900 });

    // The machine's trend opens on its servo figures: each record carries the estimate's level.
    await page.evaluate((m) => {
      window.location.hash = `#/machines/${m}/trends`;
    }, MACHINE);
    await page.waitForSelector('#trends-view:not([hidden])[data-metric="joint_level"] [data-testid="trend-chart"]');
    const levels = await page.$$eval('[data-testid="trend-point"]', (cs) => cs.map((c) => Number(c.dataset.value)));
    assert.deepEqual(levels, ids.map(() => 3));

    // A record's page: six strut charts, measured and model, as the force route answers.
    const id = ids[0];
    await page.evaluate((i) => {
      window.location.hash = `#/measurements/${i}`;
    }, id);
    await page.waitForSelector(`#detail[data-measurement-id="${id}"] [data-testid="servo-force-chart"]`);
    const force = await api.get(`/api/v1/measurements/${id}/servo/force`);
    assert.equal(force.strut_force_N.length, SAMPLES);
    assert.equal(force.strut_model_N.length, SAMPLES);
    const charts = await page.$$eval('[data-testid="strut-force"]', (svgs) =>
      svgs.map((s) => ({ strut: Number(s.dataset.strut), series: [...s.querySelectorAll('.force-line')].map((p) => [p.dataset.series, Number(p.dataset.points), p.getAttribute('d').split(/[ML]/).length - 1]) })),
    );
    assert.deepEqual(charts.map((c) => c.strut), [1, 2, 3, 4, 5, 6]);
    for (const c of charts) assert.deepEqual(c.series, [['measured', SAMPLES, SAMPLES], ['model', SAMPLES, SAMPLES]], `strut ${c.strut}`);
    const dash = await page.$eval('[data-testid="strut-force"] .force-line.model', (p) => getComputedStyle(p).strokeDasharray);
    assert.notEqual(dash, 'none', 'the model is dashed');
    await page.locator('[data-testid="servo-force-chart"]').screenshot({ path: join(outDir, 'servo-force.png') });
  });
});
