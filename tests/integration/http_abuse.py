#!/usr/bin/env python3
"""A bounded abuse load generator for the HTTP servers of ips-view and ips-phone-imu (issue 26):
real sockets on loopback, one process, every wait bounded. Shares connect_from with
http_starve.py (whose probe times genuine requests meanwhile).

  http_abuse.py attack PORT --get PATH --post PATH --stream PATH --ready FILE --stats FILE
                [--flood 1000] [--flood-from 127.0.0.10,...] [--reopen-per-s 200]
                [--rounds 3] [--cases-per-s 20] [--cases-at-once 4] [--bad-from 127.0.0.30,...]
                [--body-limit 4096] [--body-limit-status 400]
                [--slow-readers 4] [--slow-from 127.0.0.40,...] [--slow-kinds pipeline,stream]
                [--pipeline 400] [--settle-s 0] [--max-s 240]
    --flood N      N connections at once that send nothing, spread over the --flood-from
                   addresses (so that the per-address limit is met as well as the total); each
                   one the server closes is opened again, at most --reopen-per-s a second in all.
    --rounds K     K rounds of every case of cases() (oversized request heads and bodies, a body
                   of exactly --body-limit bytes that is not JSON (answered --body-limit-status),
                   malformed requests, resets mid-request), each on a new connection from the
                   --bad-from addresses in turn, --cases-at-once at a time; then --cases-per-s
                   until the end. Each case is given 30 s.
    --slow-readers M  M connections from the --slow-from addresses in turn that ask and never
                   read, with a 4 KiB receive buffer: --pipeline GETs of --get pipelined on one,
                   or a GET of --stream (an event stream), as --slow-kinds says in turn. Their
                   requests go before the flood; they are held to the end.
  --ready FILE is written once the flood has been opened once, the --rounds have been answered,
  and --settle-s have passed since the slow readers sent their requests (a server evicts a
  client that takes nothing of its response after its header timeout); the abuse goes on until
  SIGTERM, then the counts go to --stats (JSON) and it exits 0; after --max-s: exit 1.
  Counts: flood {opened, closed_by_server, connect_failed, statuses {code: n}}; cases {name:
  {sent, expect, statuses {code: n}, no_reply, unfinished (at SIGTERM), mismatched}}; slow {opened, sent_bytes, ...}.

  http_abuse.py check STATS SERVER_LOG [--handler-case NAME] [--out FILE]
    Reads the last "HTTP connections: ..." line of the server's log (core/http_server's
    stats_text, logged at exit) and asserts it against STATS: every case got its expected
    status at least once and never another one (408 and 503 aside: evicted or no slot); the
    server counted at least as many of each status as the clients were answered (cases named by
    --handler-case are answered by a handler, not refused: left out); no more 431, 413, 505,
    501, 417, 411 than the cases that cause them were sent, and some; some aborted mid-request;
    some evicted. Prints the counts (JSON, also to --out); exits 1 with "FAIL: ..." lines.
"""
import argparse
import json
import os
import random
import re
import selectors
import signal
import socket
import struct
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from http_starve import connect_from  # noqa: E402


def cases(a):
    """(name, bytes to send, expected status, reset after sending) for each case."""
    get, post = a.get, a.post
    rnd = random.Random(26)
    garbage = bytes(rnd.randrange(256) for _ in range(3000)).replace(b'\n', b'\xff')
    big_line = b'a' * (1 << 20)
    big_body = b'{' + b'x' * (2 << 20)
    h = b'Host: 127.0.0.1\r\n'
    return [
        # Oversized: a 1 MiB header line (431 once 8 KiB are in), a Content-Length beyond any
        # limit (413 before a byte of body), a 2 MiB body actually sent (413 at the head).
        ('head_1mib', b'GET ' + get + b' HTTP/1.1\r\n' + h + b'X-Big: ' + big_line +
         b'\r\n\r\n', 431, False),
        ('cl_huge', b'POST ' + post + b' HTTP/1.1\r\n' + h +
         b'Content-Length: 99999999999\r\n\r\n', 413, False),
        ('body_2mib', b'POST ' + post + b' HTTP/1.1\r\n' + h + b'Content-Length: %d\r\n\r\n'
         % len(big_body) + big_body, 413, False),
        # A body of exactly --body-limit bytes (not JSON): held whole, then refused.
        ('body_at_limit', b'POST ' + post + b' HTTP/1.1\r\n' + h + b'Content-Length: %d\r\n\r\n'
         % a.body_limit + b'[' * a.body_limit, a.body_limit_status, False),
        ('cl_overflow', b'POST ' + post + b' HTTP/1.1\r\n' + h +
         b'Content-Length: 18446744073709551616\r\n\r\n', 400, False),
        # Malformed.
        ('garbage', garbage + b'\r\n\r\n', 400, False),
        ('nul_bytes', b'\0' * 200 + b'\r\n\r\n', 400, False),
        ('nul_in_line', b'GET /\0 HTTP/1.1\r\n' + h + b'\r\n', 400, False),
        ('http_0_9', b'GET ' + get + b'\r\n\r\n', 400, False),
        ('http_2', b'GET ' + get + b' HTTP/2.0\r\n' + h + b'\r\n', 505, False),
        ('bad_request_line', b'GET  ' + get + b'  HTTP/1.1\r\n' + h + b'\r\n', 400, False),
        ('bad_method', b'G\x01T ' + get + b' HTTP/1.1\r\n' + h + b'\r\n', 400, False),
        ('bad_header', b'GET ' + get + b' HTTP/1.1\r\n' + h + b'no colon here\r\n\r\n', 400,
         False),
        ('cl_negative', b'POST ' + post + b' HTTP/1.1\r\n' + h + b'Content-Length: -1\r\n\r\n',
         400, False),
        ('cl_text', b'POST ' + post + b' HTTP/1.1\r\n' + h + b'Content-Length: ten\r\n\r\n',
         400, False),
        ('cl_twice', b'POST ' + post + b' HTTP/1.1\r\n' + h +
         b'Content-Length: 1\r\nContent-Length: 2\r\n\r\nab', 400, False),
        ('post_no_length', b'POST ' + post + b' HTTP/1.1\r\n' + h + b'\r\n', 411, False),
        ('chunked_junk', b'POST ' + post + b' HTTP/1.1\r\n' + h +
         b'Transfer-Encoding: chunked\r\n\r\nzz\r\n' + garbage[:500] + b'\r\n0\r\n\r\n', 501,
         False),
        ('expect_junk', b'POST ' + post + b' HTTP/1.1\r\n' + h +
         b'Expect: 200-ok\r\nContent-Length: 2\r\n\r\n{}', 417, False),
        # A good request, then junk on the same connection: the answer, then 400.
        ('pipelined_junk', b'GET /no-such-path HTTP/1.1\r\n' + h + b'\r\n' + garbage[:200] +
         b'\r\n\r\n', 400, False),
        # Reset (RST) after part of a head, or of a body: no answer to expect.
        ('reset_in_head', b'GET ' + get + b' HTTP/1.1\r\nHost: 127.', None, True),
        ('reset_in_body', b'POST ' + post + b' HTTP/1.1\r\n' + h +
         b'Content-Length: 1000\r\n\r\n{"payload": [', None, True),
    ]


class Conn:
    __slots__ = ('sock', 'kind', 'source', 'out', 'sent', 'reply', 'case', 'reset', 'start',
                 'read')

    def __init__(self, sock, kind, source, out=b'', case=None, reset=False, read=True):
        self.sock, self.kind, self.source = sock, kind, source
        self.out, self.sent, self.reply = out, 0, b''
        self.case, self.reset, self.start, self.read = case, reset, time.monotonic(), read


def statuses_in(reply):
    """The status codes of the responses in `reply` (several when pipelined)."""
    found, i = [], 0
    while True:
        i = reply.find(b'HTTP/1.1 ', i)
        if i < 0 or i + 12 > len(reply):
            return found
        try:
            found.append(int(reply[i + 9:i + 12]))
        except ValueError:
            pass
        i += 12


def bump(d, key, n=1):
    d[str(key)] = d.get(str(key), 0) + n


def run(a):
    stopping = []
    signal.signal(signal.SIGTERM, lambda *_: stopping.append(1))
    t_start = time.monotonic()
    sel = selectors.DefaultSelector()
    flood_from = a.flood_from.split(',')
    bad_from = a.bad_from.split(',')
    st = {'flood': {'opened': 0, 'closed_by_server': 0, 'connect_failed': 0, 'statuses': {}},
          'cases': {}, 'slow': {'opened': 0, 'closed_by_server': 0, 'sent_bytes': 0}}
    todo = []
    all_cases = cases(a)
    for name, data, expect, reset in all_cases:
        st['cases'][name] = {'sent': 0, 'expect': expect, 'statuses': {}, 'no_reply': 0,
                             'unfinished': 0, 'mismatched': 0}
    case_rounds = 0
    cases_done = 0
    case_tokens = 0.0
    conns = {}
    flood_pending = [flood_from[i % len(flood_from)] for i in range(a.flood)]
    flood_opened_once = 0
    case_source = 0
    running_cases = 0
    reopen_tokens, last_refill = float(a.flood), time.monotonic()

    def register(c):
        conns[c.sock] = c
        ev = selectors.EVENT_READ | (selectors.EVENT_WRITE if c.out else 0)
        sel.register(c.sock, ev)

    def finish(c, closed_by_server, at_stop=False):
        nonlocal running_cases, cases_done
        sel.unregister(c.sock)
        del conns[c.sock]
        codes = statuses_in(c.reply)
        if c.kind == 'flood':
            st['flood']['closed_by_server'] += 1 if closed_by_server else 0
            for s in codes:
                bump(st['flood']['statuses'], s)
            flood_pending.append(c.source)
        elif c.kind == 'slow':
            st['slow']['closed_by_server'] += 1 if closed_by_server else 0
        else:
            running_cases -= 1
            cases_done += 1
            cs = st['cases'][c.case]
            for s in codes:
                bump(cs['statuses'], s)
            if not codes:
                cs['unfinished' if at_stop else 'no_reply'] += 1
            elif cs['expect'] is not None and codes[-1] != cs['expect'] and \
                    codes[-1] not in (408, 503):
                cs['mismatched'] += 1
        if c.reset:
            c.sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack('ii', 1, 0))
        c.sock.close()

    def drain(c):
        while len(c.reply) < 65536:
            try:
                data = c.sock.recv(65536)
            except OSError:
                return
            if not data:
                return
            c.reply += data

    # The slow readers: pipelined GETs, and event streams, never read.
    slow_from = a.slow_from.split(',')
    for i in range(a.slow_readers):
        s = connect_from(slow_from[i % len(slow_from)], a.port, rcvbuf=4096)
        if s is None:
            print('FAIL: cannot connect a slow reader', file=sys.stderr)
            return 1
        st['slow']['opened'] += 1
        req = b'GET %s HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n'
        kind = a.slow_kinds.split(',')[i % len(a.slow_kinds.split(','))]
        out = req % a.get * a.pipeline if kind == 'pipeline' else req % a.stream
        c = Conn(s, 'slow', slow_from[i % len(slow_from)], out, read=False)
        conns[s] = c
        sel.register(s, selectors.EVENT_WRITE)

    slow_held = []  # slow readers that have sent their requests: never read, polled below
    next_slow_check = 0.0

    def slow_closed(c):
        """The server has closed (FIN or RST): the socket left ESTABLISHED (tcp_info's state)."""
        return c.sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_INFO, 8)[0] != 1

    ready_written = False
    slow_sent_at = None
    while not stopping:
        now = time.monotonic()
        if now - t_start > a.max_s:
            print('FAIL: no SIGTERM within %g s' % a.max_s, file=sys.stderr)
            return 1
        reopen_tokens = min(float(a.flood), reopen_tokens + (now - last_refill) * a.reopen_per_s)
        # The first --rounds at once, then --cases-per-s.
        case_tokens = min(16.0, case_tokens + (now - last_refill) * a.cases_per_s)
        last_refill = now
        if not todo:
            todo = [(n, d, r) for n, d, _, r in reversed(all_cases)]
            case_rounds += 1
        slow_sent = all(c.sent == len(c.out) for c in conns.values() if c.kind == 'slow')
        # The slow readers' requests go first (else the flood could evict them before).
        while slow_sent and flood_pending and reopen_tokens >= 1:
            source = flood_pending[-1]
            s = connect_from(source, a.port)
            if s is None:
                st['flood']['connect_failed'] += 1
                break
            flood_pending.pop()
            reopen_tokens -= 1
            st['flood']['opened'] += 1
            flood_opened_once = min(a.flood, flood_opened_once + 1)
            register(Conn(s, 'flood', source))
        while slow_sent and todo and running_cases < a.cases_at_once and \
                (case_rounds <= a.rounds or case_tokens >= 1):
            name, data, reset = todo[-1]
            source = bad_from[case_source % len(bad_from)]
            s = connect_from(source, a.port)
            if s is None:
                break
            todo.pop()
            if case_rounds > a.rounds:
                case_tokens -= 1
            case_source += 1
            running_cases += 1
            st['cases'][name]['sent'] += 1
            register(Conn(s, 'case', source, data, case=name, reset=reset))
        if slow_sent and slow_sent_at is None:
            slow_sent_at = time.monotonic()
        if not ready_written and slow_sent_at is not None and \
                time.monotonic() - slow_sent_at >= a.settle_s and flood_opened_once >= a.flood and \
                cases_done >= a.rounds * len(all_cases) and slow_sent:
            with open(a.ready, 'w') as f:
                f.write('%.1f\n' % (time.monotonic() - t_start))
            ready_written = True
        for key, ev in sel.select(timeout=0.02):
            c = conns.get(key.fileobj)
            if c is None:
                continue
            if ev & selectors.EVENT_WRITE and c.sent < len(c.out):
                try:
                    n = c.sock.send(memoryview(c.out)[c.sent:c.sent + 262144])
                    c.sent += n
                    if c.kind == 'slow':
                        st['slow']['sent_bytes'] += n
                except BlockingIOError:
                    pass
                except OSError:  # reset: what the server said before is still to be read
                    drain(c)
                    finish(c, True)
                    continue
                if c.sent == len(c.out):
                    if c.reset:  # sent its part: reset now
                        finish(c, False)
                        continue
                    # A slow reader is watched no more (see below); the others read.
                    if c.read:
                        sel.modify(c.sock, selectors.EVENT_READ)
                    else:
                        sel.unregister(c.sock)
                        del conns[c.sock]
                        slow_held.append(c)
                continue
            if ev & selectors.EVENT_READ:
                try:
                    data = c.sock.recv(65536)
                except BlockingIOError:
                    continue
                except OSError:
                    data = b''
                if data:
                    if len(c.reply) < 65536:
                        c.reply += data[:65536 - len(c.reply)]
                    continue
                finish(c, True)
        if time.monotonic() >= next_slow_check:
            next_slow_check = time.monotonic() + 0.5
            for c in [c for c in slow_held if slow_closed(c)]:
                slow_held.remove(c)
                st['slow']['closed_by_server'] += 1
                c.sock.close()
        # Cases are given 30 s (the server's timeouts are shorter).
        for c in [c for c in conns.values() if c.kind == 'case' and
                  time.monotonic() - c.start > 30]:
            finish(c, False)
    for c in list(conns.values()):
        finish(c, False, at_stop=True)
    st['slow']['held_to_the_end'] = len(slow_held)
    for c in slow_held:
        c.sock.close()
    replied = {}
    for cs in st['cases'].values():
        for code, n in cs['statuses'].items():
            bump(replied, code, n)
    st['replied'] = replied
    st['elapsed_s'] = round(time.monotonic() - t_start, 1)
    with open(a.stats, 'w') as f:
        json.dump(st, f, indent=1, sort_keys=True)
    return 0


def server_counts(log):
    """The counts of the last "HTTP connections: ..." line of a server's log (core/http_server's
    stats_text): {'accepted': n, ..., 'refusals': {status: n}}."""
    line = [x for x in open(log, errors='replace') if 'HTTP connections: ' in x]
    if not line:
        raise AssertionError('no "HTTP connections:" line in ' + log)
    text = line[-1].split('HTTP connections: ', 1)[1].strip()
    counts, _, refusals = text.partition('; refusals: ')
    c = {}
    evicted = re.search(r'(\d+) evicted \((\d+) not reading, (\d+) streams\)', counts)
    c['evicted_readers'], c['evicted_streams'] = int(evicted[2]), int(evicted[3])
    counts = counts.replace(evicted[0], evicted[1] + ' evicted')
    for part in counts.split(', '):
        n, name = part.split(' ', 1)
        c[name.split(' (')[0].replace(' mid-request', '').replace(' ', '_')] = int(n)
    c['refusals'] = {}
    for part in filter(None, refusals.split(', ')):
        status, n = part.split(' x')
        c['refusals'][status] = int(n)
    return c


def check(a):
    """Asserts what the server counted against what the generator sent and saw."""
    st = json.load(open(a.stats))
    srv = server_counts(a.server_log)
    ref = srv['refusals']
    cs = st['cases']
    problems = []
    # Every case got its expected answer at least once (others may have been evicted by the
    # flood before their bytes arrived: 408), and never another answer.
    for name, c in sorted(cs.items()):
        if c['expect'] is not None and c['statuses'].get(str(c['expect']), 0) == 0:
            problems.append('%s: never answered %d (%s)' % (name, c['expect'], c))
        if c['mismatched']:
            problems.append('%s: %d answered other than %s' % (name, c['mismatched'], c['expect']))
    # The server counted at least what the clients saw, status by status.
    seen = {}
    for name, c in cs.items():
        if name not in (a.handler_case or []):
            for code, n in c['statuses'].items():
                bump(seen, code, n)
    for code, n in st['flood']['statuses'].items():
        seen[code] = seen.get(code, 0) + n
    for code, n in sorted(seen.items()):
        if code.startswith('2'):
            continue
        if ref.get(code, 0) < n:
            problems.append('status %s: the server counted %d, the clients saw %d' %
                            (code, ref.get(code, 0), n))
    # Statuses only some cases can cause: the server counted no more than they were sent.
    sent = {name: c['sent'] for name, c in cs.items()}
    only = {'431': ['head_1mib'], '505': ['http_2'], '501': ['chunked_junk'],
            '417': ['expect_junk'], '411': ['post_no_length'],
            '413': ['cl_huge', 'body_2mib'] + (['body_at_limit'] if cs['body_at_limit']['expect']
                                               == 413 else [])}
    for code, names in only.items():
        most = sum(sent[n] for n in names)
        if not 0 < ref.get(code, 0) <= most:
            problems.append('status %s: the server counted %d, more than the %d sent or none' %
                            (code, ref.get(code, 0), most))
    resets = sent['reset_in_head'] + sent['reset_in_body']
    if not 0 < srv['aborted'] <= sum(sent.values()):
        problems.append('aborted mid-request: %d (resets sent: %d, cases sent: %d)' %
                        (srv['aborted'], resets, sum(sent.values())))
    if not (srv['evicted'] > 0 and ref.get('408', 0) >= srv['evicted']):
        problems.append('evicted %d, 408 counted %d' % (srv['evicted'], ref.get('408', 0)))
    if srv['accepted'] + srv['refused'] < st['flood']['closed_by_server']:
        problems.append('the flood saw %d connections closed, the server accepted %d + refused %d'
                        % (st['flood']['closed_by_server'], srv['accepted'], srv['refused']))
    summary = {'server': srv, 'cases_sent': sum(sent.values()), 'sent': sent, 'resets_sent': resets,
               'flood_opened': st['flood']['opened'],
               'flood_closed_by_server': st['flood']['closed_by_server'],
               'slow_readers': st['slow']['opened'], 'clients_saw': seen}
    print(json.dumps(summary, sort_keys=True))
    if a.out:
        json.dump(summary, open(a.out, 'w'))
    for p in problems:
        print('FAIL: ' + p, file=sys.stderr)
    return 1 if problems else 0


def main():
    top = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    sub = top.add_subparsers(dest='cmd', required=True)
    ck = sub.add_parser('check')
    ck.add_argument('stats')
    ck.add_argument('server_log')
    ck.add_argument('--handler-case', action='append',
                    help='a case answered by a handler, not refused (e.g. body_at_limit)')
    ck.add_argument('--out')
    p = sub.add_parser('attack')
    p.add_argument('port', type=int)
    p.add_argument('--get', default='/', type=lambda s: s.encode())
    p.add_argument('--post', default='/data', type=lambda s: s.encode())
    p.add_argument('--stream', default='/events', type=lambda s: s.encode())
    p.add_argument('--ready', required=True)
    p.add_argument('--stats', required=True)
    p.add_argument('--flood', type=int, default=1000)
    p.add_argument('--flood-from', default=','.join('127.0.0.%d' % i for i in range(10, 18)))
    p.add_argument('--reopen-per-s', type=float, default=200)
    p.add_argument('--rounds', type=int, default=3)
    p.add_argument('--cases-per-s', type=float, default=20)
    p.add_argument('--cases-at-once', type=int, default=4)
    p.add_argument('--body-limit', type=int, default=4096)
    p.add_argument('--body-limit-status', type=int, default=400)
    p.add_argument('--bad-from', default=','.join('127.0.0.%d' % i for i in range(30, 38)))
    p.add_argument('--slow-readers', type=int, default=4)
    p.add_argument('--slow-from', default='127.0.0.40')
    p.add_argument('--pipeline', type=int, default=400)
    p.add_argument('--slow-kinds', default='pipeline,stream')
    p.add_argument('--max-s', type=float, default=240)
    p.add_argument('--settle-s', type=float, default=0)
    a = top.parse_args()
    return run(a) if a.cmd == 'attack' else check(a)


if __name__ == '__main__':
    sys.exit(main())
