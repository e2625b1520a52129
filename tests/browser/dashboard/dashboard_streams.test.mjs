// Browser test of the kinemetric dashboard (web/static) against the real kinemetricd:
// sensor streams (counts, gaps, a downsampled envelope) and a Modbus device polled from a real
// Modbus TCP server. Compares what is drawn with the API's numbers and takes screenshots.
//
//   node tests/browser/dashboard/dashboard_streams.test.mjs PATH/TO/kinemetricd [OUTPUT_DIR]
//
// (session.mjs: the server, the browser, the environment.)

import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { existsSync } from 'node:fs';
import { join } from 'node:path';
import {
  outDir, MACHINE, apiGet, shown, runDashboard,
} from './session.mjs';

runDashboard('streams', async ({ step, page, server, pageErrors }) => {
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
});
