// Sensor streams and Modbus devices: device status (connected, last sample, error counts), the
// streams with their sample and gap counts, and a plot of one channel — every sample when few,
// else the min/max envelope with the mean, from the server's downsampling — with recorded gaps
// shaded. "Live" refreshes every second.

import { apiFetch } from './api.js';
import { shell } from './shell.js';
import { mayDo } from './roles.js';
import { axesGrid, chartWidth, el, r2, ticks } from './charts.js';
import { $, asProblem, h, problemContent, readNumberField, setMessage } from './dom.js';
import { formatTimestamp, plural } from './format.js';

const state = { streams: [], selected: null, stream: null, channel: null, timer: null, busy: false };

function fmtInt(n) {
  return Number(n).toLocaleString('en-GB');
}

function fmtTime(us) {
  if (!us) return '—';
  return formatTimestamp(new Date(us / 1000), { seconds: true });
}

function fmtAge(us) {
  if (!us) return 'no sample yet';
  const s = (Date.now() * 1000 - us) / 1e6;
  if (s < 0) return 'just now';
  if (s < 120) return `${s.toFixed(1)} s ago`;
  if (s < 7200) return `${(s / 60).toFixed(0)} min ago`;
  return `${(s / 3600).toFixed(1)} h ago`;
}

function showError(box, err) {
  box.replaceChildren(h('p', { class: 'message error' }, err.message || String(err)));
}

function table(headers, rows, attrs = {}) {
  return h(
    'table',
    { class: 'figures small streams-table', ...attrs },
    h('thead', {}, h('tr', {}, headers.map((t) => h('th', { scope: 'col' }, t)))),
    h('tbody', {}, rows),
  );
}

function renderDevices(items) {
  const box = $('#devices');
  if (!items.length) {
    box.replaceChildren(
      h('p', { class: 'note' }, 'No Modbus devices are being polled. Add them in the server configuration (modbus_config) or with POST /api/v1/devices.'),
    );
    return;
  }
  const rows = items.map((d) => {
    const s = d.status;
    const ok = s.connected;
    return h(
      'tr',
      { 'data-device': d.name },
      h('th', { scope: 'row' }, d.name),
      h('td', {}, d.machine_id),
      h('td', {}, `${d.config.host}:${d.config.port} unit ${d.config.unit_id}`),
      h('td', { 'data-col': 'state' }, h('span', { class: ok ? 'badge ok' : 'badge warn' }, s.state)),
      h('td', { 'data-col': 'last' }, fmtAge(s.last_sample_t_us)),
      h('td', { 'data-col': 'polls', class: 'num' }, fmtInt(s.polls_ok)),
      h('td', { 'data-col': 'skipped', class: 'num' }, fmtInt(s.skipped_ticks)),
      h('td', { 'data-col': 'exceptions', class: 'num' }, fmtInt(s.exceptions)),
      h('td', { 'data-col': 'timeouts', class: 'num' }, fmtInt(s.timeouts)),
      h('td', { 'data-col': 'connection_errors', class: 'num' }, fmtInt(s.connection_errors)),
      h('td', { 'data-col': 'reconnects', class: 'num' }, fmtInt(s.reconnects)),
      h('td', { class: 'wrap' }, s.last_error || '—'),
      h('td', {}, h('button', { type: 'button', class: 'secondary small', onclick: () => selectStream(d.stream_id) }, `#${d.stream_id}`)),
    );
  });
  box.replaceChildren(
    table(
      ['Device', 'Machine', 'Address', 'State', 'Last sample', 'Polls ok', 'Skipped ticks', 'Exceptions', 'Timeouts', 'Connection errors', 'Reconnects', 'Last error', 'Stream'],
      rows,
      { 'data-testid': 'devices-table' },
    ),
  );
}

// The streams of the selected machine (all of them without one, or with "all machines" ticked).
function shownStreams() {
  const machine = shell.getMachineId ? shell.getMachineId() : null;
  const all = !machine || $('#streams-all').checked;
  $('#streams-heading').textContent = all ? 'Sensor streams and Modbus devices' : `Sensor streams of ${machine} and Modbus devices`;
  return all ? state.streams : state.streams.filter((s) => s.machine_id === machine || s.id === state.selected);
}

function renderStreamList() {
  const box = $('#streams-list');
  if (!state.streams.length) {
    box.replaceChildren(h('p', { class: 'note' }, 'No streams yet. Clients open one with POST /api/v1/streams and send frames to /api/v1/streams/{id}/frames.'));
    return;
  }
  const streams = shownStreams();
  if (!streams.length) {
    box.replaceChildren(h('p', { class: 'note', 'data-testid': 'streams-none-here' }, `No stream of this machine; ${state.streams.length} of other machines (tick “all machines”).`));
    return;
  }
  const rows = streams.map((s) => {
    const last = Math.max(0, ...s.channels.map((c) => c.last_t_us));
    return h(
      'tr',
      { 'data-stream': s.id, class: s.id === state.selected ? 'selected' : '' },
      h('th', { scope: 'row' }, h('button', { type: 'button', class: 'link', onclick: () => selectStream(s.id) }, `#${s.id}`)),
      h('td', {}, s.machine_id),
      h('td', {}, s.name || '—'),
      h('td', {}, s.source),
      h('td', { class: 'num' }, s.channels.length),
      h('td', { 'data-col': 'samples', class: 'num' }, fmtInt(s.samples)),
      h('td', { 'data-col': 'gaps', class: 'num' }, s.gap_count ? `${fmtInt(s.gap_count)} (${fmtInt(s.missing)} missing)` : '0'),
      h('td', {}, fmtTime(last)),
    );
  });
  box.replaceChildren(
    table(['Stream', 'Machine', 'Name', 'Source', 'Channels', 'Samples', 'Gaps', 'Last sample'], rows, { 'data-testid': 'streams-table' }),
  );
}

// A channel as it was declared when the stream was opened ({channel, name?, unit?} in the
// stream's metadata): its name (else "channel N") and unit (else µm, the stream's default).
function channelInfo(stream, channel) {
  const declared = Array.isArray(stream?.metadata?.channels) ? stream.metadata.channels : [];
  const d = declared.find((c) => Number(c.channel) === Number(channel)) || {};
  const name = typeof d.name === 'string' && d.name ? d.name : `channel ${channel}`;
  const unit = typeof d.unit === 'string' && d.unit ? d.unit : 'µm';
  return { name, unit, label: d.name ? `${d.name} (channel ${channel})` : `channel ${channel}` };
}

function renderChart(data, gaps, channel, streamId, info = channelInfo(null, channel)) {
  // Drawn at the width of its box, so that its text keeps its size in CSS pixels on a phone.
  const W = chartWidth($('#stream-chart'));
  const narrow = W < 600;
  const H = 300;
  const L = narrow ? 62 : 70;
  const R = 16;
  const T = 20;
  const B = 50;
  const t = data.t_us;
  const fig = $('#stream-chart');
  if (!t.length) {
    fig.replaceChildren(h('p', { class: 'note' }, `${info.label} has no samples yet.`));
    return;
  }
  const t0 = t[0];
  const xs = t.map((v) => (v - t0) / 1e6);
  const lo = data.downsampled ? data.min_um : data.value_um;
  const hi = data.downsampled ? data.max_um : data.value_um;
  const mid = data.downsampled ? data.mean_um : data.value_um;
  let ylo = Math.min(...lo);
  let yhi = Math.max(...hi);
  const pad = (yhi - ylo) * 0.08 || 0.05;
  ylo -= pad;
  yhi += pad;
  const xmin = xs[0];
  const xmax = xs[xs.length - 1] > xmin ? xs[xs.length - 1] : xmin + 1;
  const px = (v) => L + ((v - xmin) / (xmax - xmin)) * (W - L - R);
  const py = (v) => T + (1 - (v - ylo) / (yhi - ylo)) * (H - T - B);
  const svg = el('svg', {
    viewBox: `0 0 ${W} ${H}`,
    width: W,
    height: H,
    role: 'img',
    class: 'chart stream-chart',
    'data-testid': 'stream-svg',
    'data-stream': streamId,
    'data-channel': channel,
    'data-points': t.length,
    'data-downsampled': String(data.downsampled),
    'data-samples': data.samples_in_range,
    'aria-label': `${info.label}: value in ${info.unit} against time, ${plural(data.samples_in_range, 'sample')}${data.downsampled ? ` in ${plural(t.length, 'bucket')}` : ''}.`,
  });
  svg.append(axesGrid({ W, H, L, R, T, B, px, py, xt: ticks(xmin, xmax, narrow ? 4 : 8), yt: ticks(ylo, yhi, 6) }));
  // Recorded gaps of this channel, shaded where they fall in the plotted span.
  const gapLayer = el('g', { class: 'gaps' });
  for (const g of gaps) {
    if (g.channel !== channel) continue;
    const a = Math.max(xmin, (g.t_before_us - t0) / 1e6);
    const b = Math.min(xmax, (g.t_after_us - t0) / 1e6);
    if (b < xmin || a > xmax) continue;
    gapLayer.append(
      el('rect', { x: r2(px(a)), y: T, width: Math.max(2, r2(px(b) - px(a))), height: H - T - B, class: 'gap', 'data-missing': g.missing },
        el('title', {}, `gap: ${plural(g.missing, 'sample')} missing from counter ${g.first_missing}`)),
    );
  }
  svg.append(gapLayer);
  // Break the drawing where samples are missing (a gap, or the stream paused): consecutive
  // points further apart than 1.5 bucket widths (or 3 sample periods) are not joined.
  const diffs = xs.slice(1).map((x, i) => x - xs[i]).sort((a, b) => a - b);
  const step = data.downsampled ? data.bucket_us / 1e6 : diffs.length ? diffs[Math.floor(diffs.length / 2)] : 0;
  const limit = data.downsampled ? 1.5 * step : 3 * step;
  const segments = [];
  let start = 0;
  for (let i = 1; i <= xs.length; i += 1) {
    if (i === xs.length || (limit > 0 && xs[i] - xs[i - 1] > limit)) {
      segments.push([start, i]);
      start = i;
    }
  }
  for (const [a, b] of segments) {
    const idx = [...Array(b - a).keys()].map((k) => a + k);
    if (data.downsampled) {
      const upper = idx.map((i) => `${r2(px(xs[i]))},${r2(py(hi[i]))}`);
      const lower = idx.map((i) => `${r2(px(xs[i]))},${r2(py(lo[i]))}`).reverse();
      svg.append(el('polygon', { points: [...upper, ...lower].join(' '), class: 'envelope' }));
    }
    svg.append(el('polyline', { points: idx.map((i) => `${r2(px(xs[i]))},${r2(py(mid[i]))}`).join(' '), class: 'series' }));
  }
  svg.setAttribute('data-segments', segments.length);
  svg.append(el('text', { x: r2(L + (W - L - R) / 2), y: H - 10, 'text-anchor': 'middle', class: 'axis-title' }, `time since ${fmtTime(t0)} (s)`));
  const my = r2((T + H - B) / 2);
  svg.append(el('text', { x: 16, y: my, 'text-anchor': 'middle', class: 'axis-title', transform: `rotate(-90 16 ${my})`, 'data-testid': 'stream-axis-title' }, `${info.name} (${info.unit})`));
  const caption = data.downsampled
    ? `${plural(data.samples_in_range, 'sample', 'samples', fmtInt)} shown as ${plural(t.length, 'time bucket')}: band = min … max of each bucket, line = mean.`
    : `${plural(data.samples_in_range, 'sample', 'samples', fmtInt)}, every one drawn.`;
  fig.replaceChildren(svg, h('figcaption', { class: 'note' }, caption));
}

function renderGaps(gaps) {
  const box = $('#stream-gaps');
  if (!gaps.length) {
    box.replaceChildren(h('p', { class: 'note', 'data-testid': 'stream-no-gaps' }, 'No gaps: every counter arrived.'));
    return;
  }
  const rows = gaps.map((g) =>
    h(
      'tr',
      {},
      h('td', { class: 'num' }, g.channel),
      h('td', { class: 'num' }, fmtInt(g.first_missing)),
      h('td', { class: 'num', 'data-col': 'missing' }, fmtInt(g.missing)),
      h('td', {}, fmtTime(g.t_before_us)),
      h('td', { class: 'num' }, ((g.t_after_us - g.t_before_us) / 1000).toFixed(1)),
    ),
  );
  box.replaceChildren(
    h('h4', {}, 'Recorded gaps'),
    table(['Channel', 'First missing counter', 'Missing samples', 'Last sample before', 'Gap length (ms)'], rows, { 'data-testid': 'gaps-table' }),
  );
}

async function refreshSelected() {
  const id = state.selected;
  if (id === null) return;
  const s = await apiFetch(`/api/v1/streams/${id}`);
  if (state.selected !== id) return; // another stream was chosen meanwhile
  state.stream = s;
  renderProfileChoices(s);
  const sel = $('#stream-channel');
  const chans = s.channels.map((c) => c.channel);
  if (state.channel === null || !chans.includes(state.channel)) state.channel = chans.length ? chans[0] : null;
  const labels = chans.map((c) => channelInfo(s, c).label);
  const current = [...sel.options].map((o) => o.textContent);
  if (current.join('\n') !== labels.join('\n')) {
    sel.replaceChildren(...chans.map((c, i) => h('option', { value: c }, labels[i])));
  }
  if (state.channel !== null) sel.value = String(state.channel);
  $('#stream-title').textContent = `Stream #${s.id} — ${s.machine_id}${s.name ? `, ${s.name}` : ''} (${s.source})`;
  const summary = s.channels.map((c) => `${channelInfo(s, c.channel).label}: ${plural(c.samples, 'sample', 'samples', fmtInt)}, ${plural(c.gaps, 'gap')}`).join(' · ');
  $('#stream-summary').textContent = summary || 'no samples yet';
  const gaps = (await apiFetch(`/api/v1/streams/${id}/gaps?limit=1000`)).items;
  if (state.selected !== id) return;
  if (state.channel === null) {
    $('#stream-chart').replaceChildren(h('p', { class: 'note' }, 'No samples yet.'));
  } else {
    const win = $('#stream-window').value;
    const q = new URLSearchParams({ channel: String(state.channel), max_points: '600' });
    if (win !== 'all') {
      const last = Math.max(...s.channels.map((c) => c.last_t_us));
      q.set('from_us', String(last - Number(win) * 1e6));
    }
    const data = await apiFetch(`/api/v1/streams/${id}/samples?${q}`);
    if (state.selected !== id) return;
    renderChart(data, gaps, state.channel, id, channelInfo(s, state.channel));
  }
  renderGaps(gaps);
}

async function selectStream(id) {
  state.selected = id;
  state.channel = null;
  $('#stream-detail').hidden = false;
  renderStreamList();
  try {
    await refreshSelected();
  } catch (err) {
    showError($('#stream-chart'), err);
  }
}

export async function refreshStreams() {
  if (state.busy) return;
  state.busy = true;
  try {
    // Devices are the admin's: another role lists the streams only.
    const [devices, streams] = await Promise.all([mayDo('admin') ? apiFetch('/api/v1/devices') : null, apiFetch('/api/v1/streams?limit=100')]);
    if (devices) renderDevices(devices.items);
    state.streams = streams.items;
    renderStreamList();
    if (state.selected !== null) await refreshSelected();
    $('#streams-updated').textContent = `updated ${formatTimestamp(new Date(), { seconds: true })}`;
  } catch (err) {
    showError($('#streams-list'), err);
  } finally {
    state.busy = false;
  }
}

function setLive(on) {
  if (state.timer) clearInterval(state.timer);
  state.timer = on ? setInterval(refreshStreams, 1000) : null;
}

// ---------------------------------------------------------------- stream → straightness profile

// The position choices: feed × time, or another channel of the stream as the encoder.
function renderProfileChoices(s) {
  const sel = $('#profile-position');
  const others = s.channels.map((c) => c.channel).filter((c) => c !== state.channel);
  const want = ['feed', ...others.map(String)];
  if ([...sel.options].map((o) => o.value).join(',') !== want.join(',')) {
    sel.replaceChildren(
      h('option', { value: 'feed' }, 'feed × time'),
      ...others.map((c) => h('option', { value: String(c) }, `encoder: ${channelInfo(s, c).label}`)),
    );
  }
  const feed = sel.value === 'feed';
  $('#profile-feed').disabled = !feed;
  $('#profile-start').disabled = !feed;
}

// Cuts the chosen span of the shown channel into a straightness profile on the server
// (POST /api/v1/streams/{id}/profile, docs/streams.md), stored and analysed like an upload.
async function onMakeProfile(event) {
  event.preventDefault();
  const msg = $('#profile-message');
  const s = state.stream;
  if (!s || state.channel === null) return;
  const ch = s.channels.find((c) => c.channel === state.channel);
  if (!ch) return;
  const pos = $('#profile-position').value;
  // Each number as the page reads every typed number ("0,39" is 0.39); a refusal names its field.
  const fields = [
    ['from', '#profile-from', '“From (s)”', { min: 0 }],
    ['to', '#profile-to', '“To (s)”', { min: 0 }],
    ...(pos === 'feed' ? [['feed', '#profile-feed', '“Feed (mm/min)”', {}], ['start', '#profile-start', '“Start (mm)”', { optional: true }]] : []),
  ];
  const v = {};
  for (const [key, sel, name, opts] of fields) {
    const r = readNumberField($(sel), name, opts);
    if (r.error) {
      $(sel).focus();
      setMessage(msg, 'error', ...problemContent({ title: 'No profile', detail: `${r.error}.`, field: name.slice(1, -1) }));
      return;
    }
    v[key] = r.empty ? 0 : r.value;
  }
  if (!(v.to > v.from)) {
    $('#profile-to').setAttribute('aria-invalid', 'true');
    setMessage(msg, 'error', h('strong', { class: 'problem-title' }, 'No span'), h('span', { class: 'problem-detail' }, 'Give “from” and “to” in seconds after the first sample, “to” after “from”.'));
    return;
  }
  const { from, to } = v;
  const body = {
    channel: state.channel,
    from_us: Math.round(ch.first_t_us + from * 1e6),
    to_us: Math.round(ch.first_t_us + to * 1e6),
    axis: $('#profile-axis').value,
    error_direction: $('#profile-direction').value,
  };
  body.position = pos === 'feed' ? { feed_mm_min: v.feed, start_mm: v.start } : { encoder_channel: Number(pos) };
  setMessage(msg, 'info', 'Making the profile…');
  try {
    const out = await apiFetch(`/api/v1/streams/${s.id}/profile`, { method: 'POST', body: JSON.stringify(body), headers: { 'Content-Type': 'application/json' } });
    const r = out.results || {};
    msg.dataset.measurementId = out.id;
    setMessage(
      msg,
      'success',
      'Stored as ',
      h('a', { href: `#/measurements/${out.id}`, 'data-testid': 'profile-link' }, `measurement #${out.id}`),
      typeof r.straightness_min_zone_um === 'number' ? ` — straightness ${r.straightness_min_zone_um.toFixed(3)} µm (minimum zone).` : '.',
    );
  } catch (err) {
    delete msg.dataset.measurementId;
    setMessage(msg, 'error', ...problemContent(asProblem(err, 'No profile')));
  }
}

export function initStreams() {
  $('#profile-form').addEventListener('submit', onMakeProfile);
  $('#profile-position').addEventListener('change', () => state.stream && renderProfileChoices(state.stream));
  $('#streams-refresh').addEventListener('click', refreshStreams);
  $('#streams-all').addEventListener('change', renderStreamList);
  window.addEventListener('hashchange', () => setTimeout(renderStreamList, 0));
  $('#streams-live').addEventListener('change', (e) => setLive(e.target.checked));
  $('#stream-channel').addEventListener('change', (e) => {
    state.channel = Number(e.target.value);
    refreshSelected().catch((err) => showError($('#stream-chart'), err));
  });
  $('#stream-window').addEventListener('change', () => refreshSelected().catch((err) => showError($('#stream-chart'), err)));
}
