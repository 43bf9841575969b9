// ips-view's live page: a snapshot (GET /api/state) and the floor map (GET /map.svg) at load,
// then both again from the event stream /events ("state": JSON, "map": SVG), a few times a
// second. Every string that came off the bus is put in the page as text (textContent,
// setAttribute), never as markup; the map's SVG is escaped by ips-view and parsed as XML.
'use strict';
(function () {
  const STALE_S = 5;
  const $ = (id) => document.getElementById(id);

  function fixed(v, digits) {
    return (v === null || v === undefined) ? '–' : Number(v).toFixed(digits);
  }

  function cell(row, text, cls) {
    const td = document.createElement('td');
    td.textContent = text;
    if (cls) td.className = cls;
    row.appendChild(td);
    return td;
  }

  function fill(tbody, rows) {
    tbody.replaceChildren(...rows);
  }

  function showTracks(tracks) {
    const sorted = [...tracks].sort((a, b) =>
      a.tag < b.tag ? -1 : a.tag > b.tag ? 1 : a.channel < b.channel ? -1 : a.channel > b.channel ? 1 : 0);
    const rows = sorted.map((t) => {
      const tr = document.createElement('tr');
      tr.dataset.channel = t.channel;
      tr.dataset.tag = t.tag;
      if (t.age_s > STALE_S) tr.className = 'stale';
      cell(tr, t.tag, 'tag').title = t.tag;
      const ch = cell(tr, '');
      const dot = document.createElement('span');
      dot.className = 'swatch';
      dot.style.background = t.colour;
      ch.append(dot, document.createTextNode(t.channel));
      cell(tr, fixed(t.position[0], 2), 'num x');
      cell(tr, fixed(t.position[1], 2), 'num y');
      cell(tr, fixed(t.position[2], 2), 'num z');
      const e = t.ellipse_2sigma;
      cell(tr, e ? fixed(e.semi_major_m, 2) + ' × ' + fixed(e.semi_minor_m, 2) : '–', 'num');
      cell(tr, fixed(t.age_s, 1), 'num');
      cell(tr, t.flags.join(' '));
      cell(tr, t.source);
      return tr;
    });
    fill($('tracks').tBodies[0], rows);
  }

  function showChannels(channels) {
    fill($('channels').tBodies[0], channels.map((c) => {
      const tr = document.createElement('tr');
      tr.dataset.channel = c.channel;
      if (c.age_s > STALE_S) tr.className = 'stale';
      cell(tr, c.channel, 'tag').title = c.channel;
      cell(tr, String(c.count), 'num');
      cell(tr, fixed(c.rate_hz, 1), 'num');
      cell(tr, fixed(c.age_s, 1), 'num');
      cell(tr, fixed(c.bytes_per_s, 0), 'num');
      return tr;
    }));
  }

  function showProcesses(processes) {
    fill($('processes').tBodies[0], processes.map((p) => {
      const tr = document.createElement('tr');
      tr.dataset.source = p.source;
      if (p.age_s > STALE_S) tr.className = 'stale';
      cell(tr, p.source, 'tag').title = p.source + (p.version ? ' ' + p.version : '');
      cell(tr, p.host, 'tag').title = p.host;
      cell(tr, String(p.pid), 'num');
      cell(tr, p.age_s > STALE_S ? 'silent' : p.state, p.state);
      cell(tr, String(p.msgs_in), 'num');
      cell(tr, String(p.msgs_out), 'num');
      cell(tr, String(p.parse_errors), 'num');
      cell(tr, String(p.drops), 'num');
      cell(tr, String(p.kernel_drops + p.queue_drops), 'num').title =
          p.kernel_drops + ' by the kernel (receive buffer ' + p.recv_buf_bytes + ' bytes), ' +
          p.queue_drops + ' by the LCM queue';
      cell(tr, String(p.seq_lost), 'num');
      cell(tr, fixed(p.age_s, 1), 'num');
      cell(tr, p.consistency || '', 'error').title =
          'innovations against the assumed noise (1.0x: consistent)';
      cell(tr, p.last_error, 'error');
      return tr;
    }));
  }

  function showState(s) {
    $('site').textContent = s.site ? 'site: ' + s.site.name : 'no site yet' +
        (s.site_error ? ' (last SITE refused: ' + s.site_error + ')' : '');
    $('clock').textContent = new Date(s.now_utime / 1000).toISOString().replace('T', ' ')
        .replace('Z', ' UTC');
    showTracks(s.tracks);
    showChannels(s.channels);
    showProcesses(s.processes);
    const dropped = Object.entries(s.stats).filter(([k, v]) => k.startsWith('dropped') && v > 0);
    $('stats').textContent = s.stats.poses_in + ' poses, ' + s.stats.bytes_messages_in +
        ' messages seen' + (dropped.length ? '; ' + dropped.map(([k, v]) => k + ' ' + v).join(', ') : '') +
        (s.stats.non_finite_positions ? '; non-finite positions ' + s.stats.non_finite_positions : '');
  }

  function showMap(svgText) {
    const doc = new DOMParser().parseFromString(svgText, 'image/svg+xml');
    const root = doc.documentElement;
    if (root.nodeName !== 'svg') return;  // a parse error document: keep the last map
    $('map').replaceChildren(document.importNode(root, true));
  }

  function connected(ok, text) {
    const c = $('connection');
    c.textContent = text;
    c.className = ok ? 'good' : 'bad';
  }

  fetch('/api/info').then((r) => r.json()).then((info) => {
    $('source').textContent = info.mode === 'log'
      ? 'log ' + info.log + (info.speed > 0 ? ' at ' + info.speed + '×' : ' (all at once)')
      : 'live bus ' + info.lcm_url;
  }).catch(() => {});
  fetch('/api/state?trails=0').then((r) => r.json()).then(showState).catch(() => {});
  fetch('/map.svg').then((r) => r.text()).then(showMap).catch(() => {});

  const events = new EventSource('/events');
  events.addEventListener('open', () => connected(true, 'live'));
  events.addEventListener('error', () => connected(false, 'reconnecting…'));
  events.addEventListener('state', (e) => showState(JSON.parse(e.data)));
  events.addEventListener('map', (e) => showMap(e.data));
})();
