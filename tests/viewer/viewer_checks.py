#!/usr/bin/env python3
"""Checks of a running ips-view, for tests/viewer/*.sh (Python standard library only).

  viewer_checks.py endpoints URL --mode live|log [--log LOG]
      every HTTP route: the page and its files (with their security headers), /api/info,
      /api/state (with and without trails), /map.svg (well-formed XML), the event stream,
      HEAD, and the refusals (404, 405 with Allow). With --log: the served state holds every
      TRUTH message of the log (its count) and ended where the log ends. With --mode live it
      first waits (at most 60 s) for the site and tag T1 on every --channels.
  viewer_checks.py browser URL --webdriver URL --screenshot PNG --payload TEXT
      drives Debian's headless Chromium through chromedriver (W3C WebDriver over HTTP): loads the
      page, waits for tag T1 on TRUTH and POSE_UWB, checks that it moves in the table and on the
      map and that the estimate is near the truth, that the channel and process tables are
      filled, that a tag named PAYLOAD (markup) is shown as text and ran nothing, that the
      browser logged no error, and saves a screenshot.
Exits 1 with "FAIL: ..." on the first failed check.
"""
import argparse
import base64
import json
import math
import socket
import sys
import time
import urllib.error
import urllib.parse
import urllib.request
import xml.etree.ElementTree as ET

SVG = '{http://www.w3.org/2000/svg}'


def fail(what):
    print('FAIL: ' + what, file=sys.stderr)
    sys.exit(1)


def check(ok, what):
    if not ok:
        fail(what)


def http(url, method='GET', body=None, timeout=10):
    """(status, headers dict lower-cased, body bytes); HTTP errors are returned, not raised."""
    req = urllib.request.Request(url, data=body, method=method)
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return r.status, {k.lower(): v for k, v in r.headers.items()}, r.read()
    except urllib.error.HTTPError as e:
        return e.code, {k.lower(): v for k, v in e.headers.items()}, e.read()


def get_json(url):
    status, headers, body = http(url)
    check(status == 200, f'GET {url}: status {status}')
    check(headers.get('content-type', '').startswith('application/json'),
          f'GET {url}: content type {headers.get("content-type")}')
    try:
        return json.loads(body)
    except ValueError as e:
        fail(f'GET {url}: not JSON ({e}): {body[:200]!r}')


def read_events(base, want, timeout=60):
    """The first events of /events, read off a raw socket: [(name, data)] until every name in
    `want` was seen."""
    u = urllib.parse.urlparse(base)
    s = socket.create_connection((u.hostname, u.port), timeout=timeout)
    s.sendall(b'GET /events HTTP/1.1\r\nHost: x\r\nAccept: text/event-stream\r\n\r\n')
    buf = b''
    deadline = time.time() + timeout
    while b'\r\n\r\n' not in buf:
        check(time.time() < deadline, '/events: no response head')
        chunk = s.recv(65536)
        check(chunk, '/events: closed before the head')
        buf += chunk
    head, buf = buf.split(b'\r\n\r\n', 1)
    lines = head.decode().split('\r\n')
    check(lines[0].startswith('HTTP/1.1 200'), f'/events: {lines[0]}')
    headers = {l.split(':', 1)[0].lower(): l.split(':', 1)[1].strip() for l in lines[1:]}
    check(headers.get('content-type', '').startswith('text/event-stream'),
          f'/events: content type {headers.get("content-type")}')
    check('content-length' not in headers, '/events has a Content-Length')
    events, seen = [], set()
    while not set(want) <= seen:
        while b'\n\n' in buf:
            block, buf = buf.split(b'\n\n', 1)
            name, data = '', []
            for line in block.decode().split('\n'):
                if line.startswith('event: '):
                    name = line[7:]
                elif line.startswith('data: '):
                    data.append(line[6:])
            if data:
                events.append((name, '\n'.join(data)))
                seen.add(name)
        if set(want) <= seen:
            break
        check(time.time() < deadline, f'/events: saw {sorted(seen)} in {timeout} s, want {want}')
        chunk = s.recv(65536)
        check(chunk, '/events: closed')
        buf += chunk
    s.close()
    return events


def estimates_in_svg(svg_text, where):
    try:
        root = ET.fromstring(svg_text)
    except ET.ParseError as e:
        fail(f'{where}: not well-formed XML: {e}')
    check(root.tag == SVG + 'svg', f'{where}: root element {root.tag}')
    return [c for c in root.iter(SVG + 'circle') if c.get('class') == 'estimate']


def endpoints(a):
    base = a.url.rstrip('/')
    status, headers, body = http(base + '/')
    check(status == 200, f'GET /: status {status}')
    check(headers.get('content-type') == 'text/html; charset=utf-8', f'GET /: {headers}')
    csp = headers.get('content-security-policy', '')
    check("script-src 'self'" in csp and "default-src 'self'" in csp, f'GET /: CSP {csp!r}')
    check(headers.get('x-content-type-options') == 'nosniff', 'GET /: no nosniff')
    check(b'<script src="/view.js"></script>' in body, 'GET /: the page does not load view.js')
    check(b'http://' not in body.replace(b'http://www.w3.org', b'') and b'https://' not in body,
          'GET /: the page refers to another site')
    for path, ctype, marker in (('/view.js', 'text/javascript; charset=utf-8', b'EventSource'),
                                ('/view.css', 'text/css; charset=utf-8', b'#map')):
        status, headers, body = http(base + path)
        check(status == 200 and headers.get('content-type') == ctype and marker in body,
              f'GET {path}: status {status}, type {headers.get("content-type")}')
        check(b'https://' not in body and b'http://' not in body.replace(b'http://www.w3.org', b''),
              f'GET {path}: refers to another site')
    status, headers, body = http(base + '/', method='HEAD')
    check(status == 200 and body == b'', f'HEAD /: status {status}, {len(body)} body bytes')

    info = get_json(base + '/api/info')
    check(info.get('program') == 'ips-view' and info.get('mode') == a.mode, f'/api/info: {info}')

    def live_ready(s):
        tracks = {(t['channel'], t['tag']) for t in s.get('tracks', [])}
        truth = [t for t in s.get('tracks', []) if (t['channel'], t['tag']) == ('TRUTH', 'T1')]
        return (s.get('site') and all((ch, 'T1') in tracks for ch in a.channels.split(',')) and
                truth and len(truth[0].get('trail', [])) >= 2)
    if a.mode == 'live':
        t0 = time.time()
        poll(lambda: get_json(base + '/api/state'), live_ready, 60,
             f'the site and T1 on {a.channels}')
        print(f'live: the site and T1 on {a.channels} after {time.time() - t0:.1f} s')
    state = get_json(base + '/api/state')
    for k in ('site', 'anchors', 'tracks', 'channels', 'processes', 'stats'):
        check(k in state, f'/api/state: no "{k}"')
    check(state['site'] is not None and state['site']['name'] == 'lab',
          f'/api/state: site {state["site"]}')
    check(len(state['anchors']) == 12, f'/api/state: {len(state["anchors"])} anchors (lab has 12)')
    tracks = {(t['channel'], t['tag']): t for t in state['tracks']}
    for ch in a.channels.split(','):
        check((ch, 'T1') in tracks, f'/api/state: no track of T1 on {ch}: {sorted(tracks)}')
    truth = tracks[('TRUTH', 'T1')]
    check(all('trail' in t for t in state['tracks']), '/api/state: a track without its trail')
    check(len(truth['trail']) >= 2, f'/api/state: TRUTH trail {len(truth["trail"])}')
    channels = {c['channel']: c for c in state['channels']}
    for ch in ('SITE', 'TRUTH', 'UWB_RANGE'):
        check(ch in channels and channels[ch]['count'] > 0, f'/api/state: channel {ch} not counted')
    brief = get_json(base + '/api/state?trails=0')
    check(brief['tracks'] and all('trail' not in t for t in brief['tracks']),
          '/api/state?trails=0 still has trails')

    status, headers, body = http(base + '/map.svg')
    check(status == 200 and headers.get('content-type') == 'image/svg+xml; charset=utf-8',
          f'GET /map.svg: status {status}, {headers.get("content-type")}')
    circles = estimates_in_svg(body, '/map.svg')
    check(len(circles) >= len(a.channels.split(',')),
          f'/map.svg: {len(circles)} estimates drawn')

    # The page draws the map itself: the stream carries the state (and in log mode the
    # playback's place), not the SVG.
    events = read_events(base, ['state', 'playback'] if a.mode == 'log' else ['state'])
    for name, data in events:
        check(name != 'map', '/events still sends the map')
        if name == 'state':
            s = json.loads(data)
            check(s['tracks'] and all('trail' not in t for t in s['tracks']),
                  '/events state: no tracks, or trails in it')
        elif name == 'playback':
            p = json.loads(data)
            check(p['duration_s'] > 0 and 0 <= p['position_s'] <= p['duration_s'],
                  f'/events playback: {p}')
    # The page holds the state it was served with.
    status, headers, body = http(base + '/')
    check(b'<script type="application/json" id="initial-state">{"info":' in body,
          'GET /: no initial state in the page')
    site = get_json(base + '/api/site')
    check(site['name'] == 'lab' and len(site['anchors']) == 12 and 'floors' in site and
          'zones' in site, f'/api/site: {str(site)[:300]}')

    status, headers, body = http(base + '/no/such/page')
    check(status == 404 and json.loads(body)['status'] == 'error', f'GET /no/such/page: {status}')
    status, headers, body = http(base + '/api/state', method='POST', body=b'{}')
    check(status == 405 and 'GET' in headers.get('allow', ''),
          f'POST /api/state: status {status}, Allow {headers.get("allow")}')

    if a.log:
        import lcm_log
        truth_events = sum(1 for e in lcm_log.events(a.log)[0] if e[0] == 'TRUTH')
        check(info['log_done'] is True, '/api/info: the log is not done (--speed 0)')
        check(truth['count'] == truth_events,
              f'TRUTH T1 count {truth["count"]}, the log has {truth_events} TRUTH messages')
        print(f'log: all {truth_events} TRUTH messages shown')
    print(f'endpoints ok: {len(state["tracks"])} tracks, {len(channels)} channels, '
          f'{len(state["processes"])} processes, {len(circles)} estimates on the map, '
          f'events {[n for n, _ in events]}')


class WebDriver:
    def __init__(self, url):
        self.url = url.rstrip('/')
        self.sid = None

    def call(self, method, path, body=None, timeout=60):
        data = json.dumps(body).encode() if body is not None else None
        req = urllib.request.Request(self.url + path, data=data, method=method,
                                     headers={'Content-Type': 'application/json'})
        try:
            with urllib.request.urlopen(req, timeout=timeout) as r:
                return json.load(r)['value']
        except urllib.error.HTTPError as e:
            fail(f'webdriver {method} {path}: {e.code} {e.read()[:500]!r}')

    def start(self):
        caps = {'capabilities': {'alwaysMatch': {
            'browserName': 'chrome',
            'goog:loggingPrefs': {'browser': 'ALL'},
            'goog:chromeOptions': {
                'binary': '/usr/bin/chromium',
                'args': ['--headless=new', '--no-sandbox', '--disable-gpu',
                         '--disable-dev-shm-usage', '--window-size=1400,1000',
                         '--no-first-run', '--disable-extensions'],
            }}}}
        self.sid = self.call('POST', '/session', caps)['sessionId']

    def s(self, method, path, body=None):
        return self.call(method, f'/session/{self.sid}{path}', body)

    def js(self, script):
        return self.s('POST', '/execute/sync', {'script': script, 'args': []})

    def quit(self):
        if self.sid:
            self.call('DELETE', f'/session/{self.sid}')
            self.sid = None


TABLE_JS = """
return [...document.querySelectorAll('#tracks tbody tr')].map(r => ({
  channel: r.dataset.channel, tag: r.dataset.tag,
  cells: [...r.cells].map(c => c.textContent)}));
"""
# The estimates the page drew on its canvas (window.ipsView.drawn), each with the canvas's own
# pixel at its centre: a marker the page lists but did not paint has alpha 0 there.
MARKERS_JS = """
const c = document.getElementById('map-canvas'), r = window.devicePixelRatio || 1;
const ctx = c.getContext('2d');
return window.ipsView.drawn.map(d => ({
  channel: d.channel, tag: d.tag, title: d.channel + ' ' + d.tag + ' (', cx: d.x, cy: d.y,
  alpha: ctx.getImageData(Math.round(d.x * r), Math.round(d.y * r), 1, 1).data[3]}));
"""


def poll(fn, until, timeout, what):
    deadline = time.time() + timeout
    while True:
        v = fn()
        if until(v):
            return v
        if time.time() > deadline:
            fail(f'{what} within {timeout} s; last seen: {str(v)[:800]}')
        time.sleep(0.25)


def xy(rows, channel, tag):
    for r in rows:
        if r['channel'] == channel and r['tag'] == tag:
            return float(r['cells'][2]), float(r['cells'][3])
    return None


def marker(markers, channel, tag):
    for m in markers:
        if m['channel'] == channel and m['tag'] == tag:
            check(m['alpha'] > 0, f'{channel} {tag} is listed as drawn at {m["cx"]:.0f}, {m["cy"]:.0f} '
                  'but the canvas is empty there')
            return m['cx'], m['cy']
    return None


def browser(a):
    wd = WebDriver(a.webdriver)
    wd.start()
    try:
        wd.s('POST', '/url', {'url': a.url})
        t0 = time.time()
        rows = poll(lambda: wd.js(TABLE_JS),
                    lambda rows: xy(rows, 'TRUTH', 'T1') and xy(rows, 'POSE_UWB', 'T1'),
                    60, 'the page shows T1 on TRUTH and POSE_UWB')
        print(f'page shows T1 after {time.time() - t0:.1f} s: {len(rows)} estimate rows')
        first = xy(rows, 'TRUTH', 'T1')
        first_marker = poll(lambda: marker(wd.js(MARKERS_JS), 'TRUTH', 'T1'), bool, 60,
                            'the map draws TRUTH T1')
        # The walker goes at 1 m/s: within a few seconds the table and the map must follow.
        moved = poll(lambda: wd.js(TABLE_JS),
                     lambda rows: xy(rows, 'TRUTH', 'T1') and
                     math.dist(xy(rows, 'TRUTH', 'T1'), first) >= 1.0,
                     60, 'TRUTH T1 moves 1 m in the table')
        # The map is redrawn apart from the table: it follows within the same bound.
        moved_marker = poll(lambda: marker(wd.js(MARKERS_JS), 'TRUTH', 'T1'),
                            lambda m: m and math.dist(m, first_marker) >= 10, 60,
                            f'TRUTH T1 moves 10 px on the map from {first_marker}')
        # One snapshot of the table: the estimate within a metre of the truth (a snapshot
        # taken while the estimator is a moment behind on a loaded machine is taken again).
        near = poll(lambda: wd.js(TABLE_JS),
                    lambda rows: xy(rows, 'TRUTH', 'T1') and xy(rows, 'POSE_UWB', 'T1') and
                    math.dist(xy(rows, 'TRUTH', 'T1'), xy(rows, 'POSE_UWB', 'T1')) <= 1.0,
                    60, 'POSE_UWB T1 within 1 m of TRUTH T1 in the table')
        truth, est = xy(near, 'TRUTH', 'T1'), xy(near, 'POSE_UWB', 'T1')
        print(f'T1 moved {math.dist(first, truth):.2f} m in the table, '
              f'{math.dist(first_marker, moved_marker):.0f} px on the map; '
              f'POSE_UWB {est} vs TRUTH {truth}')

        channels = wd.js("return [...document.querySelectorAll('#channels tbody tr')].map("
                         "r => [...r.cells].map(c => c.textContent));")
        by_name = {c[0]: c for c in channels}
        for ch in ('SITE', 'TRUTH', 'UWB_RANGE', 'POSE_UWB', 'HEALTH'):
            check(ch in by_name, f'channel table has no {ch}: {sorted(by_name)}')
        # The rate is measured over the last seconds: a stall of the simulator lowers it a while.
        channels = poll(lambda: wd.js("return [...document.querySelectorAll('#channels tbody tr')]"
                                      ".map(r => [...r.cells].map(c => c.textContent));"),
                        lambda rows: any(r[0] == 'UWB_RANGE' and float(r[2]) >= 5 for r in rows),
                        60, 'UWB_RANGE at 5 Hz or more in the channel table')
        by_name = {c[0]: c for c in channels}
        procs = poll(lambda: wd.js("return [...document.querySelectorAll('#processes tbody tr')]"
                                   ".map(r => [...r.cells].map(c => c.textContent));"),
                     lambda p: any(r[0] == 'ips-uwb-twr' and r[3] == 'ok' for r in p), 60,
                     'the process table shows ips-uwb-twr ok')
        print(f'channel table: {len(channels)} rows (UWB_RANGE {by_name["UWB_RANGE"][2]} Hz); '
              f'processes: {sorted(r[0] for r in procs)}')

        # The tag named with markup is text in the table and on the map, and ran nothing.
        payload = a.payload
        shown = poll(lambda: wd.js(
            "return [...document.querySelectorAll('#tracks tbody tr')].filter("
            "r => r.dataset.tag === " + json.dumps(payload) + ").map(r => r.cells[0].textContent);"),
            lambda v: len(v) >= 1, 60, 'the page shows the tag named ' + payload)
        check(all(v == payload for v in shown), f'the tag shows as {shown}')
        # The map cuts long labels to "<start>...".
        on_map = wd.js("const p = " + json.dumps(payload) + ";"
                       "return window.ipsView.labels.filter("
                       "t => t.tag === p && (t.text === p || (t.text.endsWith('...') &&"
                       " t.text.length > 10 && p.startsWith(t.text.slice(0, -3))))).length;")
        check(on_map >= 1, 'the map does not label the tag named ' + payload)
        injected = wd.js("return {pwned: window.pwned === undefined ? null : window.pwned, "
                         "images: document.images.length, "
                         "scripts: document.querySelectorAll('script').length, "
                         "bold: document.querySelectorAll('b').length};")
        # Two scripts: view.js and the page's initial state (JSON, not run).
        check(injected == {'pwned': None, 'images': 0, 'scripts': 2, 'bold': 0},
              f'markup from a tag name reached the page: {injected}')
        print(f'tag {payload!r}: shown as text in {len(shown)} rows and {on_map} map labels; '
              f'nothing injected {injected}')

        logs = wd.s('POST', '/se/log', {'type': 'browser'})
        errors = [l for l in logs if l.get('level') == 'SEVERE']
        check(not errors, f'the browser logged errors: {errors}')
        png = base64.b64decode(wd.s('GET', '/screenshot'))
        check(png[:8] == b'\x89PNG\r\n\x1a\n' and len(png) > 10000,
              f'screenshot: {len(png)} bytes')
        with open(a.screenshot, 'wb') as f:
            f.write(png)
        print(f'screenshot: {a.screenshot} ({len(png)} bytes); browser log: {len(logs)} entries, '
              f'no error')
    finally:
        wd.quit()


CONSOLE_MARKERS_JS = MARKERS_JS


def console(a):
    """The console of issue 24 on the log view_console_log wrote, served at --speed 1."""
    wd = WebDriver(a.webdriver)
    wd.start()
    shots = []

    def shot(name):
        png = base64.b64decode(wd.s('GET', '/screenshot'))
        check(png[:8] == b'\x89PNG\r\n\x1a\n' and len(png) > 10000, f'screenshot {name}: {len(png)} bytes')
        path = f'{a.screenshots}-{name}.png'
        with open(path, 'wb') as f:
            f.write(png)
        shots.append(path)

    def click(css):
        # Found and clicked in one script: the map and the tables are redrawn a few times a
        # second, so an element handle kept between two WebDriver calls may be gone.
        # A map marker takes the pointer (as a mouse press on it does), the rest a click.
        done = wd.js("const e = document.querySelector(" + json.dumps(css) + ");"
                     "if (!e) return false;"
                     "if (e instanceof SVGElement) e.dispatchEvent(new PointerEvent('pointerdown',"
                     " {bubbles: true, pointerId: 1}));"
                     "else e.click();"
                     "return true;")
        check(done, f'nothing to click at {css}')

    def click_marker(tag):
        # A real pointer press on the marker's pixel (WebDriver actions, from the centre of the
        # map's top layer): the page finds the estimate under it (hitTest).
        m = [x for x in wd.js(CONSOLE_MARKERS_JS) if x['tag'] == tag]
        check(m, f'no marker of {tag} on the map')
        check(all(x['alpha'] > 0 for x in m), f'{tag} listed as drawn but not painted: {m}')
        box = wd.js("const r = document.getElementById('map-svg').getBoundingClientRect();"
                    "return [r.width, r.height];")
        svg = wd.s('POST', '/element', {'using': 'css selector', 'value': '#map-svg'})
        ref = next(iter(svg.values()))
        dx, dy = int(round(m[-1]['cx'] - box[0] / 2)), int(round(m[-1]['cy'] - box[1] / 2))
        wd.s('POST', '/actions', {'actions': [{
            'type': 'pointer', 'id': 'mouse', 'parameters': {'pointerType': 'mouse'},
            'actions': [{'type': 'pointerMove', 'duration': 0,
                         'origin': {'element-6066-11e4-a52e-4f735466cecf': ref}, 'x': dx, 'y': dy},
                        {'type': 'pointerDown', 'button': 0}, {'type': 'pointerUp', 'button': 0}]}]})
        wd.s('DELETE', '/actions')

    def seek(t):
        wd.js(f"const s = document.getElementById('seek'); s.value = {t};"
              "s.dispatchEvent(new Event('input')); s.dispatchEvent(new Event('change'));")
        poll(lambda: wd.js("return window.ipsView.info.playback.position_s;"),
             lambda p: p is not None and abs(p - t) < 3, 30, f'the page at {t} s of the log')

    try:
        wd.s('POST', '/url', {'url': a.url})
        # The page drew the state it was served with (in the page: no event needed).
        first = wd.js("return {initial: !!document.getElementById('initial-state'),"
                      " svg: document.querySelectorAll('#map svg *').length};")
        check(first['initial'] and first['svg'] > 5, f'the first snapshot is not drawn: {first}')
        # Pause, then seek to 30 s: T1 on floor 1, T2 and T10 on floor 0.
        click('#play')
        poll(lambda: wd.js("return window.ipsView.info.playback.paused;"), bool, 30, 'paused')
        seek(30)
        markers = poll(lambda: wd.js(CONSOLE_MARKERS_JS), lambda m: len(m) >= 1, 30, 'markers at 30 s')
        plan = wd.js("const i = document.querySelector('#map image.plan');"
                     " return i ? [i.dataset.floor, i.getAttribute('href').slice(0, 26)] : null;")
        check(plan is not None and plan[1] == 'data:image/svg+xml;base64,', f'no floor plan on the map: {plan}')
        print(f'seek 30 s: {len(markers)} markers, floor plan of floor {plan[0]}')
        # Natural sort of the tags table.
        tags = wd.js("return [...document.querySelectorAll('#tags tbody tr')].map(r => r.dataset.tag);")
        check(tags == ['T1', 'T2', 'T10'], f'tags table order {tags}')
        # Follow T1 by clicking its marker on the map... it is on floor 1: choose it first.
        wd.js("const f = document.getElementById('floor'); f.value = '1'; f.dispatchEvent(new Event('change'));")
        poll(lambda: wd.js(CONSOLE_MARKERS_JS), lambda m: any(x['tag'] == 'T1' for x in m), 30, 'T1 on floor 1')
        click_marker('T1')
        poll(lambda: wd.js("return document.getElementById('following').textContent;"),
             lambda t: t == 'following T1', 30, 'following T1')
        detail = wd.js("return [...document.querySelectorAll('#tag-estimates tbody tr')].map(r => r.dataset.channel);")
        check(sorted(detail) == ['POSE_FUSED', 'POSE_UWB', 'TRUTH'], f'T1 detail rows {detail}')
        check('follow=T1' in wd.js("return location.hash;"), 'the URL does not keep the followed tag')
        shot('follow')
        # Seek back to 8 s: the followed tag's floor becomes 0 (ALTITUDE), the plan follows; the
        # zone event (enter, at 5 s) and its alert are listed.
        seek(8)
        poll(lambda: wd.js("return document.getElementById('floor').value;"), lambda v: v == '0', 30,
             'the floor follows T1 down to 0')
        poll(lambda: wd.js("const i = document.querySelector('#map image.plan'); return i && i.dataset.floor;"),
             lambda v: v == '0', 30, 'the plan of floor 0')
        events = poll(lambda: wd.js("return [...document.querySelectorAll('#zone-events tbody tr')]"
                                    ".map(r => [r.dataset.tag, r.dataset.zone, r.dataset.event]);"),
                      lambda e: ['T1', 'lab', 'enter'] in e, 30, 'the zone event T1 enter lab')
        alerts = poll(lambda: wd.js("return [...document.querySelectorAll('#alerts li.alert')]"
                                    ".map(l => [l.dataset.kind, l.className]);"),
                      lambda x: any(k == 'zone' and 'raised' in c for k, c in x), 30, 'the zone alert')
        badge = wd.js("const b = document.getElementById('alert-badge'); return b.hidden ? '' : b.textContent;")
        check(badge == '1 alert', f'alert badge {badge!r}')
        shot('zone-alert')
        click('#alerts li.alert[data-kind="zone"] button')
        poll(lambda: wd.js("return document.querySelector('#alerts li.alert[data-kind=\"zone\"]').className;"),
             lambda c: 'acked' in c, 30, 'the alert acknowledged')
        info = get_json(a.url.rstrip('/') + '/api/state?trails=0')
        check(any(x['kind'] == 'zone' and x['acked'] for x in info['alerts']), 'the ack did not reach ips-view')
        print(f'seek 8 s: floor 0, zone events {events}, alerts {alerts}, acked')
        # Toggle a channel and a tag.
        click('#legend label[data-channel="POSE_UWB"] input')
        m = poll(lambda: wd.js(CONSOLE_MARKERS_JS), lambda m: m and not any(x['channel'] == 'POSE_UWB' for x in m),
                 30, 'POSE_UWB hidden')
        check('hide=POSE_UWB' in wd.js("return location.hash;"), 'the URL does not keep the hidden channel')
        click('#tags tbody tr[data-tag="T2"] input')
        m = poll(lambda: wd.js(CONSOLE_MARKERS_JS), lambda m: m and not any(x['tag'] == 'T2' for x in m),
                 30, 'T2 hidden')
        check(any(x['tag'] == 'T10' for x in m), f'T10 hidden too: {m}')
        # Zoom: the anchors A1-A2 spread by the factor (the view follows T1, so measure distances).
        def spread():
            r = wd.js("return [...document.querySelectorAll('#map rect.anchor')].map(e => parseFloat(e.getAttribute('x')));")
            return max(r) - min(r) if len(r) >= 2 else 0
        before = spread()
        click('#zoom-in')
        after = poll(lambda: spread(), lambda v: v > before * 1.3, 30, f'zoom in from {before:.0f} px')
        print(f'toggles: POSE_UWB and T2 hidden; zoom {before:.0f} -> {after:.0f} px')
        shot('toggles')
        frame = wd.js("return window.ipsView.lastFrameMs;")
        print(f'last frame {frame:.1f} ms; screenshots {shots}')
        logs = wd.s('POST', '/se/log', {'type': 'browser'})
        errors = [l for l in logs if l.get('level') == 'SEVERE']
        check(not errors, f'the browser logged errors: {errors}')
    finally:
        wd.quit()


def bench(a):
    """scripts/bench-view: the page's and ips-view's costs at a given load."""
    wd = WebDriver(a.webdriver)
    wd.start()
    try:
        wd.s('POST', '/url', {'url': a.url + '#floor=all' + (('&' + a.hash) if a.hash else '')})
        time.sleep(a.seconds)  # a measurement over a fixed time, not a wait for a state
        page = wd.js("const q = (v) => { const s = [...v].sort((x, y) => x - y);"
                     " return s.length ? [s[Math.floor(s.length / 2)], s[Math.floor(s.length * 0.95)],"
                     " s[s.length - 1], s.length] : [0, 0, 0, 0]; };"
                     "return {draw: q(window.ipsView.frameMs), state: q(window.ipsView.stateMs),"
                     " update: q(window.ipsView.updateMs),"
                     " parts: window.ipsView.drawParts,"
                     " markers: window.ipsView.drawn.length,"
                     " rows: document.querySelectorAll('#tracks tbody tr').length};")
        info = get_json(a.url.rstrip('/') + '/api/info')
    finally:
        wd.quit()
    u = info['update_ms']
    print(f'bench-view: {a.label}, {a.seconds} s in headless Chromium')
    print(f'  ips-view, one page update (state JSON built and queued): mean {u["mean"]:.2f} ms, '
          f'max {u["max"]:.2f} ms over {u["count"]} updates')
    d, s = page['draw'], page['state']
    print(f'  page, map draw: median {d[0]:.1f} ms, p95 {d[1]:.1f} ms, max {d[2]:.1f} ms ({d[3]} draws, '
          f'{page["markers"]} estimates on the map)')
    print(f'  page, the last draw by layer: ' + ', '.join(f'{k} {v:.1f} ms' for k, v in page['parts'].items()))
    print(f'  page, state event (tables): median {s[0]:.1f} ms, p95 {s[1]:.1f} ms, max {s[2]:.1f} ms '
          f'({s[3]} events, {page["rows"]} estimate rows)')
    w = page['update']
    print(f'  page, the main thread\'s work for an update (parse, tables, map, style and layout; '
          f'not the paint): median {w[0]:.1f} ms, p95 {w[1]:.1f} ms, max {w[2]:.1f} ms ({w[3]} updates)')
    print(f'  goals: page frame <= 16 ms (p95 {w[1]:.1f} ms), ips-view update <= 10 ms '
          f'(max {u["max"]:.2f} ms)')


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    sub = p.add_subparsers(dest='cmd', required=True)
    e = sub.add_parser('endpoints')
    e.add_argument('url')
    e.add_argument('--mode', choices=['live', 'log'], required=True)
    e.add_argument('--log')
    e.add_argument('--channels', default='TRUTH,POSE_UWB')
    b = sub.add_parser('browser')
    b.add_argument('url')
    b.add_argument('--webdriver', required=True)
    b.add_argument('--screenshot', required=True)
    b.add_argument('--payload', required=True)
    c = sub.add_parser('console')
    c.add_argument('url')
    c.add_argument('--webdriver', required=True)
    c.add_argument('--screenshots', required=True, help='path prefix of the PNGs')
    bp = sub.add_parser('bench')
    bp.add_argument('url')
    bp.add_argument('--webdriver', required=True)
    bp.add_argument('--seconds', type=float, default=20)
    bp.add_argument('--label', default='')
    bp.add_argument('--hash', default='', help="more of the page's address, e.g. hide=TRUTH")
    a = p.parse_args()
    {'endpoints': endpoints, 'browser': browser, 'console': console, 'bench': bench}[a.cmd](a)


if __name__ == '__main__':
    main()
