// The discovery browser test's parts (discovery.test.mjs): the binaries, the environment, the
// simulated hexapod tests, the server on a free port with a fresh data dir and a bootstrap
// token, the API calls and the dashboard's number formats.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import {
  CHROMIUM_ARGS, chromiumPath, loadPlaywright, serverBin, sleep, startServer, stopServer, webDir, webRoot,
} from '../lib/harness.mjs';

export { CHROMIUM_ARGS, chromiumPath, loadPlaywright, serverBin, sleep, startServer, stopServer, webDir, webRoot };

export const here = dirname(fileURLToPath(import.meta.url));
export const repo = resolve(here, '../../..');
export const cliBin = process.argv[3] || process.env.KINEMETRIC_CLI || (serverBin ? join(dirname(serverBin), 'kinemetric') : '');
export const outDir = process.env.KINEMETRIC_BROWSER_OUT || process.argv[4] || join(tmpdir(), 'kinemetric-browser');
export const MACHINE_JSON = join(repo, 'tests/fixtures/pm600-like.json');
export const MACHINE = 'pm600-like';
export const SERIAL_FIXTURE = join(repo, 'tests/fixtures/browser/dbb_xy-r150_ccw.txt');
export const SERIAL_MACHINE = 'browser-test-vmc';
// The hidden effects of the simulated machine ([PM-600 report] values: K_stiff2 1.52e-5 mm/N,
// base-joint friction 8.88 N·m) and the two tool lengths of table 4.4.
export const SIM_ARGS = [
  'simulate', 'dbb', '--machine', MACHINE_JSON, '--absolute', '--samples', '180', '--tools', '104.255,150',
  '--effects', 'gravity_deflection:K_stiff2_mm_per_N=1.52e-5;joint_friction:torque_Nm=8.88,ramp_mm=2',
];

// ------------------------------------------------------------------ prerequisites

export function checkPrerequisites() {
  const problems = [];
  if (!serverBin) problems.push('no server binary given (first argument or KINEMETRICD)');
  else if (!existsSync(serverBin)) problems.push(`server binary ${serverBin} does not exist (build target kinemetricd)`);
  if (!cliBin || !existsSync(cliBin)) problems.push(`CLI binary '${cliBin}' does not exist (build target kinemetric; second argument or KINEMETRIC_CLI)`);
  if (!existsSync(chromiumPath)) problems.push(`${chromiumPath} is missing: install Chromium (apt-get install -y chromium; deploy/install-deps.sh)`);
  if (!existsSync(join(webRoot, 'index.html'))) problems.push(`no dashboard at ${webRoot}/index.html`);
  for (const f of [MACHINE_JSON, SERIAL_FIXTURE]) if (!existsSync(f)) problems.push(`fixture ${f} is missing`);
  if (problems.length) throw new Error(`browser_discovery cannot run:\n  - ${problems.join('\n  - ')}`);
}

// ------------------------------------------------------------------ helpers

export async function api(server, method, path, body, headers = {}) {
  const send = () => fetch(`${server.base}${path}`, { method, body, headers: { Authorization: `Bearer ${server.token}`, ...headers } });
  let r;
  try {
    r = await send();
  } catch (err) {
    // A pooled keep-alive connection the server closed just then (idle timeout): the request
    // never reached it, so it is sent once more on a new connection.
    if (err?.cause?.code !== 'UND_ERR_SOCKET') throw new Error(`${method} ${path}: ${err.message} (${err?.cause?.code}: ${err?.cause?.message})`);
    r = await send();
  }
  const text = await r.text();
  let json = null;
  try {
    json = text ? JSON.parse(text) : null;
  } catch {
    // not JSON
  }
  return { status: r.status, json, text };
}

export async function apiGet(server, path) {
  const r = await api(server, 'GET', path);
  assert.equal(r.status, 200, `GET ${path} → ${r.status} ${r.text.slice(0, 300)}`);
  return r.json;
}

export async function upload(server, name, bytes) {
  const r = await api(server, 'POST', '/api/v1/measurements', bytes, { 'Content-Type': 'text/plain', 'X-Filename': name });
  assert.ok(r.status === 201 || r.status === 200, `upload ${name}: ${r.status} ${r.text.slice(0, 300)}`);
  return r.json.id;
}

// The dashboard's µm format: 3 decimals, true minus sign, no "-0.000".
export function um3(v) {
  let s = v.toFixed(3);
  if (/^-0\.?0*$/.test(s)) s = s.slice(1);
  return s.replace('-', '−');
}

// "−1.5" → -1.5
export function shown(text) {
  return Number(String(text).replace(/\u2212/g, '-').replace(/[\s\u2009]/g, ''));
}

// Names of the analysis that must not be shown as such: snake_case words.
export const INTERNAL_NAME = /\b[A-Za-z]+[a-z0-9]*_[A-Za-z0-9_]+\b/;
