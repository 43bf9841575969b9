// ips-view's page: the map is drawn here (SVG for the site, a canvas for what moves), from the state ips-view sends (the first one is
// in the page itself, then "state" events from /events a few times a second), with the site's
// floors, plans and zones from /api/site. Channel and tag toggles, zoom and pan, the followed
// tag and the floor are kept in the URL (#...). Every string that came off the bus is put in the
// page as text (textContent, setAttribute), never as markup.
'use strict';
(function () {
  const STALE_S = 5;
  const MARKER_R = 5;  // an estimate's radius on the map, pixels
  const SVGNS = 'http://www.w3.org/2000/svg';
  const $ = (id) => document.getElementById(id);
  const natural = new Intl.Collator(undefined, {numeric: true, sensitivity: 'base'}).compare;

  const app = {
    info: null,        // /api/info
    site: null,        // /api/site
    siteVersion: -1,
    state: null,       // the latest snapshot
    trails: new Map(), // "channel\ttag" -> [[t_s, x, y], ...]
    lastCount: new Map(),
    view: null,        // {cx, cy, scale}: world point at the centre, pixels per metre
    hidden: new Set(), hiddenTags: new Set(), follow: null, floor: null,
    drawn: [], labels: [], siteKey: '',
    drawPending: false, seeking: false, lastFrameMs: 0, frameMs: [], stateMs: [], updateMs: [], size: null,
  };
  // For tests and the curious: drawn is what the last draw put on the map (channel, tag, x, y in
  // CSS pixels of the map, in drawing order), labels the tags' labels; lastFrameMs is the last draw's time, frameMs the last 200 draws,
  // stateMs the last 200 state updates' (the tables, without the draw that follows), updateMs
  // the main thread's whole work for each of the last 200 updates (parse, tables, draw, style
  // and layout; not the paint).
  window.ipsView = app;

  // ---- URL state -------------------------------------------------------------------------
  function readHash() {
    const p = new URLSearchParams(location.hash.slice(1));
    const list = (k) => (p.get(k) || '').split(',').filter((s) => s.length);
    app.hidden = new Set(list('hide'));
    app.hiddenTags = new Set(list('hidetags'));
    app.follow = p.get('follow') || null;
    app.floor = p.has('floor') ? p.get('floor') : null;
    const v = list('view').map(Number);
    if (v.length === 3 && v.every(Number.isFinite) && v[2] > 0) app.view = {cx: v[0], cy: v[1], scale: v[2]};
  }
  function writeHash() {
    const p = new URLSearchParams();
    if (app.hidden.size) p.set('hide', [...app.hidden].join(','));
    if (app.hiddenTags.size) p.set('hidetags', [...app.hiddenTags].join(','));
    if (app.follow) p.set('follow', app.follow);
    if (app.floor !== null) p.set('floor', app.floor);
    if (app.view) p.set('view', [app.view.cx.toFixed(2), app.view.cy.toFixed(2), app.view.scale.toFixed(2)].join(','));
    history.replaceState(null, '', '#' + p.toString());
  }

  // ---- helpers ---------------------------------------------------------------------------
  function fixed(v, digits) {
    return (v === null || v === undefined || !Number.isFinite(v)) ? '–' : Number(v).toFixed(digits);
  }
  function el(name, attrs, text) {
    const e = document.createElementNS(SVGNS, name);
    for (const k in attrs) e.setAttribute(k, attrs[k]);
    if (text !== undefined) e.textContent = text;
    return e;
  }
  function cell(row, text, cls, title) {
    const td = document.createElement('td');
    td.textContent = text;
    if (cls) td.className = cls;
    if (title !== undefined) td.title = title;
    row.appendChild(td);
    return td;
  }
  // Puts `rows` in the table, replacing only the rows that differ: an unchanged row is left
  // alone, so the browser has nothing to lay out again for it.
  function swatch(colour) {
    const dot = document.createElement('span');
    dot.className = 'swatch';
    dot.style.background = colour;
    return dot;
  }
  // A cell with the channel's colour and name.
  function channelCell(row, t) {
    cell(row, '').append(swatch(t.colour), document.createTextNode(t.channel));
  }
  function fill(tbody, rows) {
    const old = tbody.rows;
    if (old.length !== rows.length) { tbody.replaceChildren(...rows); return; }
    for (let i = 0; i < rows.length; ++i) if (old[i].outerHTML !== rows[i].outerHTML) old[i].replaceWith(rows[i]);
  }
  // setAttribute only when the value changes.
  function setAttrs(e, cache, attrs) {
    for (const k in attrs) {
      if (cache[k] === attrs[k]) continue;
      cache[k] = attrs[k];
      e.setAttribute(k, attrs[k]);
    }
  }
  const key = (t) => t.channel + '\t' + t.tag;
  function timeText(utime) {
    if (app.info && app.info.playback) {
      return ((utime - app.info.playback.first_utime) / 1e6).toFixed(1) + ' s';
    }
    return new Date(utime / 1000).toISOString().slice(11, 19);
  }
  function isFlat(t) { return t.flags.includes('2d'); }

  // ---- the tracks' floors and visibility -------------------------------------------------
  function floors() { return (app.site && app.site.floors) || []; }
  function currentFloor() {
    if (app.floor === null || app.floor === 'all' || !floors().length) return null;
    return Number(app.floor);
  }
  function tagFloor(tag) {
    const h = app.state && app.state.heights.find((x) => x.tag === tag);
    if (h && h.floor !== null) return h.floor;
    const tr = app.state ? app.state.tracks.filter((t) => t.tag === tag && t.floor !== null) : [];
    const fused = tr.find((t) => t.channel === 'POSE_FUSED');
    return fused ? fused.floor : (tr.length ? tr[0].floor : null);
  }
  function visible(t) {
    if (app.hidden.has(t.channel) || app.hiddenTags.has(t.tag)) return false;
    const f = currentFloor();
    return f === null || t.floor === null || t.floor === f;
  }

  // ---- the view: world <-> screen ----------------------------------------------------------
  // The map's size, measured when the page's layout changes (a ResizeObserver), not in each
  // draw: reading it there would force a layout of everything changed before.
  function mapSize() {
    if (!app.size) {
      const box = $('map').getBoundingClientRect();
      app.size = {w: Math.max(320, box.width), h: Math.max(240, Math.min(box.width * 0.75, window.innerHeight - 160))};
    }
    return app.size;
  }
  function siteBounds() {
    const xs = [], ys = [];
    const add = (x, y) => { if (Number.isFinite(x) && Number.isFinite(y)) { xs.push(x); ys.push(y); } };
    if (app.site) {
      app.site.anchors.forEach((a) => add(a.position[0], a.position[1]));
      app.site.zones.forEach((z) => z.polygon.forEach((p) => add(p[0], p[1])));
      floors().forEach((f) => { if (f.plan) { add(f.plan.origin[0], f.plan.origin[1]); add(f.plan.origin[0] + f.plan.size_m[0], f.plan.origin[1] + f.plan.size_m[1]); } });
    }
    if (app.state) app.state.tracks.forEach((t) => add(t.position[0], t.position[1]));
    if (!xs.length) return {x0: -5, x1: 5, y0: -5, y1: 5};
    return {x0: Math.min(...xs) - 1, x1: Math.max(...xs) + 1, y0: Math.min(...ys) - 1, y1: Math.max(...ys) + 1};
  }
  function fitView() {
    const b = siteBounds(), s = mapSize();
    app.view = {cx: (b.x0 + b.x1) / 2, cy: (b.y0 + b.y1) / 2,
                scale: Math.min(s.w / (b.x1 - b.x0), s.h / (b.y1 - b.y0)) * 0.95};
  }
  function toScreen(x, y, s) {
    return [(x - app.view.cx) * app.view.scale + s.w / 2, s.h / 2 - (y - app.view.cy) * app.view.scale];
  }
  function zoomAt(factor, px, py) {
    const s = mapSize(), v = app.view;
    const wx = v.cx + (px - s.w / 2) / v.scale, wy = v.cy - (py - s.h / 2) / v.scale;
    v.scale = Math.min(2000, Math.max(0.5, v.scale * factor));
    v.cx = wx - (px - s.w / 2) / v.scale;
    v.cy = wy + (py - s.h / 2) / v.scale;
    writeHash();
    requestDraw();
  }

  // ---- the map -------------------------------------------------------------------------------
  function requestDraw() {
    if (app.drawPending) return;
    app.drawPending = true;
    requestAnimationFrame(() => {
      if (!app.drawPending) return;  // drawn already in this frame
      app.drawPending = false;
      draw();
    });
  }
  function niceStep(metres) {
    const p = Math.pow(10, Math.floor(Math.log10(metres)));
    for (const m of [1, 2, 5, 10]) if (m * p >= metres) return m * p;
    return 10 * p;
  }
  // Three layers: the site (plan, grid, zones, anchors: SVG, rebuilt only when the view or the
  // site changes), the trails, ellipses, estimates and labels (a canvas, redrawn each time), and
  // the scale bar and the time (SVG, on top, which also takes the pointer).
  function drawSite(s, floor) {
    const g = document.createDocumentFragment();
    const planFloor = floor === null ? floors().find((f) => f.plan) : floors().find((f) => f.index === floor);
    if (planFloor && planFloor.plan) {
      const pl = planFloor.plan;
      const [ox, oy] = toScreen(pl.origin[0], pl.origin[1], s);
      const w = pl.size_m[0] * app.view.scale, h = pl.size_m[1] * app.view.scale;
      const img = el('image', {class: 'plan', x: ox, y: oy - h, width: w, height: h,
        preserveAspectRatio: 'none', transform: `rotate(${-pl.rotation_deg} ${ox} ${oy})`,
        'data-floor': planFloor.index});
      img.setAttribute('href', pl.uri);
      g.appendChild(img);
    }
    // A grid every nice step of about 60 px.
    const step = niceStep(60 / app.view.scale);
    const wx0 = app.view.cx - s.w / 2 / app.view.scale, wx1 = app.view.cx + s.w / 2 / app.view.scale;
    const wy0 = app.view.cy - s.h / 2 / app.view.scale, wy1 = app.view.cy + s.h / 2 / app.view.scale;
    let grid = '';
    for (let x = Math.ceil(wx0 / step) * step; x <= wx1; x += step) {
      const [sx] = toScreen(x, 0, s); grid += `M${sx.toFixed(1)} 0V${s.h}`;
    }
    for (let y = Math.ceil(wy0 / step) * step; y <= wy1; y += step) {
      const [, sy] = toScreen(0, y, s); grid += `M0 ${sy.toFixed(1)}H${s.w}`;
    }
    g.appendChild(el('path', {class: 'grid', d: grid}));
    if (app.site) {
      const occupied = new Set(insideZones().map((iz) => iz.zone));
      for (const z of app.site.zones) {
        if (floor !== null && z.floor !== null && z.floor !== floor) continue;
        const pts = z.polygon.map((p) => toScreen(p[0], p[1], s).map((v) => v.toFixed(1)).join(',')).join(' ');
        const poly = el('polygon', {class: 'zone' + (occupied.has(z.id) ? ' occupied' : ''), points: pts, 'data-zone': z.id});
        poly.appendChild(el('title', {}, z.name + (z.floor !== null ? ' (floor ' + z.floor + ')' : '')));
        g.appendChild(poly);
        const c = z.polygon.reduce((a, p) => [a[0] + p[0] / z.polygon.length, a[1] + p[1] / z.polygon.length], [0, 0]);
        const [lx, ly] = toScreen(c[0], c[1], s);
        g.appendChild(el('text', {class: 'zone-name', x: lx, y: ly}, z.name));
      }
      for (const a of app.site.anchors) {
        const [ax, ay] = toScreen(a.position[0], a.position[1], s);
        const m = el('rect', {class: 'anchor ' + a.kind + (a.enabled ? '' : ' disabled'), x: ax - 4, y: ay - 4, width: 8, height: 8});
        m.appendChild(el('title', {}, a.id + ' (' + a.kind + ')'));
        g.appendChild(m);
        g.appendChild(el('text', {class: 'anchor-id', x: ax + 6, y: ay - 6}, a.id));
      }
    }
    $('map-site').replaceChildren(g);
  }
  // The canvas: trails, ellipses, then the estimates and their tags' labels, all drawn anew each
  // time (700 SVG circles cost more in style and layout than drawing them here). What was drawn
  // is kept in app.drawn, in drawing order, for clicks and hover (hitTest) and for tests.
  function drawCanvas(s, tracks) {
    const canvas = $('map-canvas');
    const ratio = window.devicePixelRatio || 1;
    if (canvas.width !== Math.round(s.w * ratio) || canvas.height !== Math.round(s.h * ratio)) {
      canvas.width = Math.round(s.w * ratio);
      canvas.height = Math.round(s.h * ratio);
      canvas.style.width = s.w + 'px';
      canvas.style.height = s.h + 'px';
    }
    const ctx = canvas.getContext('2d');
    ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    ctx.clearRect(0, 0, s.w, s.h);
    const v = app.view, hw = s.w / 2, hh = s.h / 2;
    ctx.lineWidth = 1.2;
    ctx.globalAlpha = 0.6;
    for (const t of tracks) {
      const trail = app.trails.get(key(t));
      if (!trail || trail.length < 2) continue;
      ctx.strokeStyle = t.colour;
      ctx.beginPath();
      for (let i = 0; i < trail.length; ++i) {
        const x = (trail[i][1] - v.cx) * v.scale + hw, y = hh - (trail[i][2] - v.cy) * v.scale;
        if (i) ctx.lineTo(x, y); else ctx.moveTo(x, y);
      }
      ctx.stroke();
    }
    ctx.lineWidth = 1;
    ctx.globalAlpha = 0.7;
    for (const t of tracks) {
      const e = t.ellipse_2sigma;
      if (!e || !(e.semi_major_m * v.scale > 2)) continue;
      const [x, y] = toScreen(t.position[0], t.position[1], s);
      ctx.strokeStyle = t.colour;
      ctx.beginPath();
      ctx.ellipse(x, y, e.semi_major_m * v.scale, e.semi_minor_m * v.scale, -e.angle_deg * Math.PI / 180, 0, 2 * Math.PI);
      ctx.stroke();
    }
    ctx.globalAlpha = 1;
    // The estimates: the followed tag's last, on top, with a thicker ring; stale ones hollow.
    const drawn = [];
    const order = app.follow === null ? tracks
      : tracks.filter((t) => t.tag !== app.follow).concat(tracks.filter((t) => t.tag === app.follow));
    for (const t of order) {
      const [x, y] = toScreen(t.position[0], t.position[1], s);
      if (x < -MARKER_R || y < -MARKER_R || x > s.w + MARKER_R || y > s.h + MARKER_R) continue;
      ctx.beginPath();
      ctx.arc(x, y, MARKER_R, 0, 2 * Math.PI);
      ctx.fillStyle = t.age_s > STALE_S ? '#fff' : t.colour;
      ctx.fill();
      ctx.lineWidth = t.tag === app.follow ? 3 : 1.5;
      ctx.strokeStyle = t.colour;
      ctx.stroke();
      drawn.push({channel: t.channel, tag: t.tag, x: x, y: y, position: t.position});
    }
    // One label per tag, beside its fused estimate (or its first one).
    const labelAt = new Map();
    for (const d of drawn) if (!labelAt.has(d.tag) || d.channel === 'POSE_FUSED') labelAt.set(d.tag, d);
    ctx.font = '12px sans-serif';
    ctx.lineWidth = 3;
    ctx.lineJoin = 'round';
    ctx.strokeStyle = '#fff';
    ctx.fillStyle = '#222';
    const labels = [];
    for (const [tag, d] of labelAt) {
      const text = tag.length > 24 ? tag.slice(0, 21) + '...' : tag;
      ctx.strokeText(text, d.x + 7, d.y - 7);
      ctx.fillText(text, d.x + 7, d.y - 7);
      labels.push({tag: tag, text: text, x: d.x + 7, y: d.y - 7});
    }
    app.drawn = drawn;
    app.labels = labels;
  }
  // The estimate under a point of the map (in CSS pixels), the one drawn last winning; null if none.
  function hitTest(px, py) {
    for (let i = app.drawn.length - 1; i >= 0; --i) {
      const d = app.drawn[i];
      if ((d.x - px) * (d.x - px) + (d.y - py) * (d.y - py) <= (MARKER_R + 2) * (MARKER_R + 2)) return d;
    }
    return null;
  }
  function estimateTitle(d) {
    return `${d.channel} ${d.tag} (${fixed(d.position[0], 2)}, ${fixed(d.position[1], 2)})`;
  }
  // The scale bar and the time, on top (SVG).
  function drawDeco(s) {
    const layer = $('map-svg');
    const bar = niceStep(100 / app.view.scale), barPx = bar * app.view.scale;
    let deco = layer.querySelector('g.deco');
    if (!deco) { deco = el('g', {class: 'deco'}); layer.appendChild(deco); }
    deco.replaceChildren(
      el('path', {class: 'scale-bar', d: `M12 ${s.h - 14}h${barPx}M12 ${s.h - 19}v10M${12 + barPx} ${s.h - 19}v10`}),
      el('text', {class: 'scale-text', x: 12, y: s.h - 22}, bar >= 1 ? bar + ' m' : bar * 100 + ' cm'),
      el('text', {class: 'map-time', x: s.w - 10, y: s.h - 10}, app.state ? timeText(app.state.now_utime) : ''));
    $('map').dataset.estimates = app.drawn.length;
  }
  function draw() {
    const t0 = performance.now();
    if (!app.view) fitView();
    const s = mapSize();
    for (const id of ['map-site', 'map-svg']) {
      const svg = $(id);
      svg.setAttribute('width', s.w);
      svg.setAttribute('height', s.h);
      svg.setAttribute('viewBox', `0 0 ${s.w} ${s.h}`);
    }
    $('map').style.height = s.h + 'px';
    const floor = currentFloor();
    const occupied = insideZones().map((z) => z.zone).sort().join(',');
    const siteKey = [s.w, s.h, app.view.cx, app.view.cy, app.view.scale, floor, app.siteVersion, occupied].join('|');
    if (siteKey !== app.siteKey) {
      drawSite(s, floor);
      app.siteKey = siteKey;
    }
    const t1 = performance.now();
    const tracks = app.state ? app.state.tracks.filter(visible) : [];
    drawCanvas(s, tracks);
    const t2 = performance.now();
    drawDeco(s);
    app.drawParts = {site: t1 - t0, canvas: t2 - t1, deco: performance.now() - t2};
    app.lastFrameMs = performance.now() - t0;
    app.frameMs.push(app.lastFrameMs);
    if (app.frameMs.length > 200) app.frameMs.shift();
  }

  // ---- following a tag -------------------------------------------------------------------------
  function followTag(tag) {
    app.follow = tag;
    if (tag !== null) {
      const f = tagFloor(tag);
      if (f !== null && floors().length) { app.floor = String(f); $('floor').value = app.floor; }
    }
    writeHash();
    showFollow();
    requestDraw();
  }
  function showFollow() {
    $('following').textContent = app.follow ? 'following ' + app.follow : '';
    $('unfollow').hidden = !app.follow;
    const box = $('tag-detail');
    box.hidden = !app.follow;
    if (!app.follow || !app.state) return;
    $('tag-detail-title').textContent = app.follow + ': every estimator';
    const rows = app.state.tracks.filter((t) => t.tag === app.follow)
      .sort((a, b) => natural(a.channel, b.channel)).map((t) => {
        const tr = document.createElement('tr');
        tr.dataset.channel = t.channel;
        channelCell(tr, t);
        cell(tr, fixed(t.position[0], 2), 'num');
        cell(tr, fixed(t.position[1], 2), 'num');
        cell(tr, isFlat(t) ? '-' : fixed(t.position[2], 2), 'num');
        const e = t.ellipse_2sigma;
        cell(tr, e ? fixed(e.semi_major_m, 2) + ' × ' + fixed(e.semi_minor_m, 2) : '–', 'num');
        cell(tr, fixed(t.age_s, 1), 'num');
        const trail = app.trails.get(key(t));
        cell(tr, trail ? trail.length + ' pts' : '–', 'num');
        return tr;
      });
    fill($('tag-estimates').tBodies[0], rows);
  }
  function centreOnFollowed() {
    if (!app.follow || !app.state || !app.view) return;
    // The followed tag's floor first (its tracks are hidden on another floor).
    const f = tagFloor(app.follow);
    if (f !== null && floors().length && app.floor !== String(f) && app.floor !== 'all') {
      app.floor = String(f);
      $('floor').value = app.floor;
      writeHash();
    }
    const t = app.state.tracks.find((x) => x.tag === app.follow && x.channel === 'POSE_FUSED' && visible(x)) ||
              app.state.tracks.find((x) => x.tag === app.follow && visible(x));
    if (!t) return;
    app.view.cx = t.position[0];
    app.view.cy = t.position[1];
  }

  // ---- tables ------------------------------------------------------------------------------------
  function insideZones() {
    // From the zone events: the last event of each (tag, zone) is an enter or a dwell.
    const last = new Map();
    if (!app.state) return [];
    for (const e of [...app.state.zone_events].reverse()) last.set(e.tag + '\t' + e.zone, e);
    return [...last.values()].filter((e) => e.event !== 'leave');
  }
  function showTracks(tracks) {
    const sorted = [...tracks].filter((t) => !app.hidden.has(t.channel) && !app.hiddenTags.has(t.tag))
      .sort((a, b) => natural(a.tag, b.tag) || natural(a.channel, b.channel));
    fill($('tracks').tBodies[0], sorted.map((t) => {
      const tr = document.createElement('tr');
      tr.dataset.channel = t.channel;
      tr.dataset.tag = t.tag;
      if (t.age_s > STALE_S) tr.className = 'stale';
      cell(tr, t.tag, 'tag', t.tag);
      channelCell(tr, t);
      cell(tr, fixed(t.position[0], 2), 'num x');
      cell(tr, fixed(t.position[1], 2), 'num y');
      cell(tr, isFlat(t) ? '-' : fixed(t.position[2], 2), 'num z');
      const e = t.ellipse_2sigma;
      cell(tr, e ? fixed(e.semi_major_m, 2) + ' × ' + fixed(e.semi_minor_m, 2) : '–', 'num');
      cell(tr, fixed(t.age_s, 1), 'num');
      cell(tr, t.flags.join(' '));
      cell(tr, t.source, 'fold', t.source);
      cell(tr, t.floor === null ? '–' : String(t.floor), 'num');
      return tr;
    }));
  }
  function showTags(s) {
    const tags = [...new Set(s.tracks.map((t) => t.tag))].sort(natural);
    const zones = insideZones();
    fill($('tags').tBodies[0], tags.map((tag) => {
      const tr = document.createElement('tr');
      tr.dataset.tag = tag;
      if (tag === app.follow) tr.className = 'followed';
      const box = document.createElement('input');
      box.type = 'checkbox';
      box.checked = !app.hiddenTags.has(tag);
      box.title = 'show ' + tag + ' on the map';
      box.addEventListener('change', () => {
        if (box.checked) app.hiddenTags.delete(tag); else app.hiddenTags.add(tag);
        writeHash();
        refresh();
      });
      const td = document.createElement('td');
      td.appendChild(box);
      tr.appendChild(td);
      const name = cell(tr, tag, 'tag link', 'follow ' + tag);
      name.addEventListener('click', () => followTag(app.follow === tag ? null : tag));
      const f = tagFloor(tag);
      cell(tr, f === null ? '–' : String(f), 'num');
      const h = s.heights.find((x) => x.tag === tag);
      const best = s.tracks.find((t) => t.tag === tag && t.channel === 'POSE_FUSED' && !isFlat(t));
      cell(tr, h && !h.relative ? fixed(h.height_m, 2) : best ? fixed(best.position[2], 2) : '-', 'num');
      const zs = zones.filter((z) => z.tag === tag).map((z) => z.zone_name);
      cell(tr, zs.join(', ') || '–', 'fold', zs.join(', '));
      cell(tr, String(s.tracks.filter((t) => t.tag === tag).length), 'num');
      return tr;
    }));
  }
  function showLegend(s) {
    const channels = [...new Map(s.tracks.map((t) => [t.channel, t.colour])).entries()]
      .sort((a, b) => natural(a[0], b[0]));
    const legend = $('legend');
    const have = [...legend.querySelectorAll('label')].map((l) => l.dataset.channel).join('\n');
    if (have === channels.map((c) => c[0]).join('\n')) return;
    legend.replaceChildren(...channels.map(([ch, colour]) => {
      const label = document.createElement('label');
      label.dataset.channel = ch;
      const box = document.createElement('input');
      box.type = 'checkbox';
      box.checked = !app.hidden.has(ch);
      box.addEventListener('change', () => {
        if (box.checked) app.hidden.delete(ch); else app.hidden.add(ch);
        writeHash();
        refresh();
      });
      label.append(box, swatch(colour), document.createTextNode(ch));
      return label;
    }));
  }
  function showChannels(channels) {
    fill($('channels').tBodies[0], channels.map((c) => {
      const tr = document.createElement('tr');
      tr.dataset.channel = c.channel;
      if (c.age_s > STALE_S) tr.className = 'stale';
      cell(tr, c.channel, 'tag', c.channel);
      cell(tr, String(c.count), 'num');
      cell(tr, fixed(c.rate_hz, 1), 'num');
      cell(tr, fixed(c.age_s, 1), 'num');
      cell(tr, fixed(c.bytes_per_s, 0), 'num');
      return tr;
    }));
  }
  function showProcesses(processes) {
    fill($('processes').tBodies[0], [...processes].sort((a, b) => natural(a.source, b.source)).map((p) => {
      const tr = document.createElement('tr');
      tr.dataset.source = p.source;
      if (p.age_s > STALE_S) tr.className = 'stale';
      cell(tr, p.source, 'tag', p.source + (p.version ? ' ' + p.version : ''));
      cell(tr, p.host, 'tag', p.host);
      cell(tr, String(p.pid), 'num');
      cell(tr, p.age_s > STALE_S ? 'silent' : p.state, p.state);
      cell(tr, String(p.msgs_in), 'num');
      cell(tr, String(p.msgs_out), 'num');
      cell(tr, String(p.parse_errors), 'num');
      cell(tr, String(p.drops), 'num');
      cell(tr, String(p.kernel_drops + p.queue_drops), 'num',
           p.kernel_drops + ' by the kernel (receive buffer ' + p.recv_buf_bytes + ' bytes), ' +
           p.queue_drops + ' by the LCM queue');
      cell(tr, String(p.seq_lost), 'num');
      cell(tr, fixed(p.age_s, 1), 'num');
      cell(tr, p.consistency || '', 'error', p.consistency || '');
      cell(tr, p.last_error, 'error', p.last_error);
      return tr;
    }));
  }
  function showZoneEvents(events) {
    fill($('zone-events').tBodies[0], events.slice(0, 50).map((e) => {
      const tr = document.createElement('tr');
      tr.dataset.tag = e.tag;
      tr.dataset.zone = e.zone;
      tr.dataset.event = e.event;
      if (e.alert) tr.className = 'alerting';
      cell(tr, timeText(e.utime), 'num');
      cell(tr, e.tag, 'tag', e.tag);
      cell(tr, e.zone_name, 'tag', e.zone);
      cell(tr, e.event);
      cell(tr, e.event === 'enter' ? '–' : fixed(e.dwell_s, 1), 'num');
      return tr;
    }));
  }
  function showAlerts(alerts) {
    const list = $('alerts');
    const raised = alerts.filter((a) => a.raised && !a.acked).length;
    const badge = $('alert-badge');
    badge.hidden = raised === 0;
    badge.textContent = raised + (raised === 1 ? ' alert' : ' alerts');
    if (!alerts.length) { list.replaceChildren(Object.assign(document.createElement('li'), {className: 'note', textContent: 'none'})); return; }
    list.replaceChildren(...alerts.slice(0, 50).map((a) => {
      const li = document.createElement('li');
      li.className = 'alert ' + a.severity + (a.raised ? ' raised' : ' cleared') + (a.acked ? ' acked' : '');
      li.dataset.kind = a.kind;
      li.dataset.subject = a.subject;
      const when = document.createElement('span');
      when.className = 'when';
      when.textContent = timeText(a.raised_utime) + (a.raised ? '' : ' – ' + timeText(a.cleared_utime));
      const text = document.createElement('span');
      text.className = 'text';
      text.textContent = a.text;
      text.title = a.source + ': ' + a.text;
      li.append(when, text);
      if (!a.acked) {
        const b = document.createElement('button');
        b.type = 'button';
        b.textContent = 'ack';
        b.title = 'mark as seen (for every page)';
        b.addEventListener('click', () => {
          fetch('/api/alerts/ack?source=' + encodeURIComponent(a.source) + '&id=' + a.id, {method: 'POST'})
            .then(() => { a.acked = true; showAlerts(alerts); }).catch(() => {});
        });
        li.appendChild(b);
      }
      return li;
    }));
  }

  // ---- state in ------------------------------------------------------------------------------
  function takeTrails(s, withServerTrails) {
    const now = s.now_utime / 1e6, keep = (app.info && app.info.trail_s) || 20;
    for (const t of s.tracks) {
      const k = key(t);
      let trail = app.trails.get(k);
      if (withServerTrails && t.trail) {
        // The server's trail is the last trail_s seconds: spread it over them.
        const n = t.trail.length;
        trail = t.trail.map((p, i) => [now - t.age_s - keep * (n - 1 - i) / Math.max(1, n), p[0], p[1]]);
        app.trails.set(k, trail);
        app.lastCount.set(k, t.count);
        continue;
      }
      if (app.lastCount.get(k) === t.count) continue;
      app.lastCount.set(k, t.count);
      if (!trail) { trail = []; app.trails.set(k, trail); }
      trail.push([now - t.age_s, t.position[0], t.position[1]]);
      while (trail.length && trail[0][0] < now - keep) trail.shift();
    }
  }
  function showState(s, withServerTrails) {
    const t0 = performance.now();
    app.state = s;
    takeTrails(s, withServerTrails);
    $('site').textContent = s.site ? 'site: ' + s.site.name : 'no site yet' +
        (s.site_error ? ' (last SITE refused: ' + s.site_error + ')' : '');
    $('clock').textContent = app.info && app.info.playback ? '' :
      new Date(s.now_utime / 1000).toISOString().replace('T', ' ').replace('Z', ' UTC');
    if (s.site && s.site.version !== app.siteVersion) loadSite(s.site.version);
    refresh();
    const dropped = Object.entries(s.stats).filter(([k, v]) => k.startsWith('dropped') && v > 0);
    $('stats').textContent = s.stats.poses_in + ' poses, ' + s.stats.bytes_messages_in +
        ' messages seen' + (dropped.length ? '; ' + dropped.map(([k, v]) => k + ' ' + v).join(', ') : '') +
        (s.stats.non_finite_positions ? '; non-finite positions ' + s.stats.non_finite_positions : '');
    app.stateMs.push(performance.now() - t0);
    if (app.stateMs.length > 200) app.stateMs.shift();
  }
  function refresh() {
    const s = app.state;
    if (!s) return;
    showLegend(s);
    showTags(s);
    // The estimates table is the big one (a row per tag and channel): with more than 150 rows it
    // starts folded, and a folded table is not filled.
    const box = $('estimates-box');
    if (s.tracks.length > 150 && !app.estimatesFolded) { box.open = false; app.estimatesFolded = true; }
    if (box.open) showTracks(s.tracks);
    showChannels(s.channels);
    showProcesses(s.processes);
    showZoneEvents(s.zone_events);
    showAlerts(s.alerts);
    showFollow();
    centreOnFollowed();
    requestDraw();
  }
  function takeSite(site) {
    app.site = site;
    app.siteVersion = site.version;
    const sel = $('floor');
    const opts = [['all', 'all floors'], ...site.floors.map((f) => [String(f.index), f.name])];
    sel.replaceChildren(...opts.map(([v, text]) => Object.assign(document.createElement('option'), {value: v, textContent: text})));
    sel.disabled = site.floors.length === 0;
    if (app.floor === null && site.floors.length) app.floor = String(site.floors[0].index);
    sel.value = app.floor === null ? 'all' : app.floor;
    requestDraw();
  }
  function loadSite(version) {
    app.siteVersion = version;  // one fetch per version
    fetch('/api/site').then((r) => r.json()).then(takeSite).catch(() => { app.siteVersion = -1; });
  }
  function takeInfo(info) {
    app.info = info;
    $('source').textContent = info.mode === 'log' ? 'log ' + info.log : 'live bus ' + info.lcm_url;
    if (info.playback) showPlayback(info.playback);
  }
  function showPlayback(p) {
    app.info.playback = p;
    $('timeline').hidden = false;
    const seek = $('seek');
    seek.max = p.duration_s;
    if (!app.seeking) seek.value = p.position_s;
    $('position').textContent = fixed(p.position_s, 1) + ' / ' + fixed(p.duration_s, 1) + ' s';
    $('play').textContent = p.paused ? 'play' : 'pause';
    $('play').title = p.paused ? 'play' : 'pause';
    const sp = $('speed');
    if (![...sp.options].some((o) => Number(o.value) === p.speed))
      sp.appendChild(Object.assign(document.createElement('option'), {value: p.speed, textContent: p.speed > 0 ? p.speed + '×' : 'all at once'}));
    sp.value = String(p.speed);
    connected(true, p.done ? 'log: end' : p.paused ? 'log: paused' : 'log: playing', 'log');
  }
  function playback(query) {
    return fetch('/api/playback?' + query, {method: 'POST'}).then((r) => r.json()).then((p) => {
      if (p && p.duration_s !== undefined) showPlayback(p);
    });
  }
  function connected(ok, text, cls) {
    const c = $('connection');
    c.textContent = text;
    c.className = cls || (ok ? 'good' : 'bad');
  }

  // ---- input -------------------------------------------------------------------------------
  function wire() {
    const svg = $('map-svg');
    svg.addEventListener('wheel', (e) => {
      e.preventDefault();
      const r = svg.getBoundingClientRect();
      zoomAt(e.deltaY < 0 ? 1.2 : 1 / 1.2, e.clientX - r.left, e.clientY - r.top);
    }, {passive: false});
    let drag = null;
    const at = (e) => { const r = svg.getBoundingClientRect(); return hitTest(e.clientX - r.left, e.clientY - r.top); };
    svg.addEventListener('pointerdown', (e) => {
      const hit = at(e);
      if (hit) { followTag(hit.tag); return; }
      drag = {x: e.clientX, y: e.clientY, cx: app.view.cx, cy: app.view.cy};
      svg.setPointerCapture(e.pointerId);
    });
    svg.addEventListener('pointerleave', () => { $('map-tip').hidden = true; });
    svg.addEventListener('pointermove', (e) => {
      if (!drag) {
        // Hover: the estimate's channel, tag and position in a tip, the pointer a hand.
        const hit = at(e), tip = $('map-tip');
        svg.classList.toggle('over-estimate', !!hit);
        tip.hidden = !hit;
        if (hit) {
          tip.textContent = estimateTitle(hit);
          tip.style.left = (hit.x + 10) + 'px';
          tip.style.top = (hit.y + 8) + 'px';
        }
        return;
      }
      if (app.follow) followTag(null);
      app.view.cx = drag.cx - (e.clientX - drag.x) / app.view.scale;
      app.view.cy = drag.cy + (e.clientY - drag.y) / app.view.scale;
      requestDraw();
    });
    svg.addEventListener('pointerup', () => { if (drag) { drag = null; writeHash(); } });
    svg.addEventListener('dblclick', () => { fitView(); writeHash(); requestDraw(); });
    $('zoom-in').addEventListener('click', () => { const s = mapSize(); zoomAt(1.5, s.w / 2, s.h / 2); });
    $('zoom-out').addEventListener('click', () => { const s = mapSize(); zoomAt(1 / 1.5, s.w / 2, s.h / 2); });
    $('zoom-fit').addEventListener('click', () => { fitView(); writeHash(); requestDraw(); });
    $('unfollow').addEventListener('click', () => followTag(null));
    $('floor').addEventListener('change', (e) => { app.floor = e.target.value; writeHash(); refresh(); });
    $('play').addEventListener('click', () => playback(app.info.playback.paused ? 'action=play' : 'action=pause'));
    $('speed').addEventListener('change', (e) => playback('action=speed&speed=' + encodeURIComponent(e.target.value)));
    const seek = $('seek');
    seek.addEventListener('input', () => { app.seeking = true; $('position').textContent = fixed(Number(seek.value), 1) + ' s'; });
    seek.addEventListener('change', () => {
      const back = app.state && Number(seek.value) < app.info.playback.position_s;
      playback('action=seek&t=' + encodeURIComponent(seek.value)).then(() => {
        app.seeking = false;
        if (back) { app.trails.clear(); app.lastCount.clear(); }
        return fetch('/api/state').then((r) => r.json()).then((s) => showState(s, true));
      }).catch(() => { app.seeking = false; });
    });
    window.addEventListener('resize', () => { app.size = null; requestDraw(); });
    new ResizeObserver(() => {
      const w = $('map').getBoundingClientRect().width;
      if (app.size && Math.abs(w - app.size.w) > 0.5) { app.size = null; requestDraw(); }
    }).observe($('map'));
    $('estimates-box').addEventListener('toggle', refresh);
    window.addEventListener('keydown', (e) => { if (e.key === 'Escape') followTag(null); });
  }

  // ---- start ---------------------------------------------------------------------------------
  readHash();
  wire();
  const initial = $('initial-state');
  if (initial) {
    // The state of the moment the page was served: drawn at once, before any event.
    const first = JSON.parse(initial.textContent);
    takeInfo(first.info);
    if (first.site) takeSite(first.site);
    showState(first.state, true);
    draw();
  } else {
    fetch('/api/info').then((r) => r.json()).then(takeInfo).catch(() => {});
    fetch('/api/state').then((r) => r.json()).then((s) => showState(s, true)).catch(() => {});
  }
  const events = new EventSource('/events');
  events.addEventListener('open', () => { if (!app.info || !app.info.playback) connected(true, 'live'); });
  events.addEventListener('error', () => connected(false, 'reconnecting…'));
  events.addEventListener('state', (e) => {
    // The main thread's work for one update: this handler (parse, tables) plus the frame that
    // draws it (the map, then the style and layout of everything changed, forced here so that
    // they are counted); the paint itself is not.
    const t0 = performance.now();
    let handler = 0;
    // Registered before showState asks for its draw: this runs first in the frame, and draws.
    requestAnimationFrame(() => {
      const t1 = performance.now();
      if (app.drawPending) { app.drawPending = false; draw(); }
      void $('map').offsetHeight;  // style and layout now
      app.updateMs.push(handler + performance.now() - t1);
      if (app.updateMs.length > 200) app.updateMs.shift();
    });
    showState(JSON.parse(e.data), false);
    handler = performance.now() - t0;
  });
  events.addEventListener('playback', (e) => showPlayback(JSON.parse(e.data)));
})();
