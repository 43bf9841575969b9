#!/usr/bin/env python3
"""An HTTP server under a starvation attack, for the integration tests of ips-phone-imu's HTTP
input and ips-view (issue 28): one process holds idle connections and runs a slowloris, another
times real requests meanwhile.

  http_starve.py attack PORT --ready FILE --stats FILE [--idle 200] [--idle-from 127.0.0.2,...]
                        [--slow 10] [--slow-from 127.0.0.4] [--byte-every 0.5]
      Keeps --idle connections open that send nothing (spread over the --idle-from addresses),
      and --slow connections that send a partial request head a byte every --byte-every s;
      every connection the server closes is opened again at once. FILE --ready is written once
      every connection has been opened once; on SIGTERM the counts go to --stats (JSON) and it
      exits 0.
  http_starve.py probe PORT --method POST|GET --path P [--body-file F] [--count 20]
                       [--every 0.2] [--deadline 1.0] [--expect TEXT] [--require] [--out FILE]
      Makes --count requests from 127.0.0.1, each on a new connection, one every --every s
      (in the body, @T@ becomes 1698501144000000000 + k * 10000000 for the k-th, counted from
      --first: a phone time);
      prints the success rate and latencies (JSON to --out); with --require, exits 1 unless
      every one got a 2xx holding TEXT within --deadline s.
The sockets of one address share its ephemeral ports (IP_BIND_ADDRESS_NO_PORT: the port is
chosen at connect, per destination).
"""
import argparse
import errno
import json
import selectors
import signal
import socket
import sys
import time

IP_BIND_ADDRESS_NO_PORT = getattr(socket, 'IP_BIND_ADDRESS_NO_PORT', 24)


def connect_from(source, port, rcvbuf=None):
    """A non-blocking connection from `source` (with a receive buffer of `rcvbuf` bytes when
    given: a client slow to read fills it sooner), or None when connect fails at once."""
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if rcvbuf is not None:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    s.setsockopt(socket.SOL_IP, IP_BIND_ADDRESS_NO_PORT, 1)
    s.bind((source, 0))
    s.setblocking(False)
    rc = s.connect_ex(('127.0.0.1', port))
    if rc not in (0, errno.EINPROGRESS):
        s.close()
        return None
    return s


def attack(a):
    idle_from = a.idle_from.split(',')
    slow_from = a.slow_from.split(',')
    sel = selectors.DefaultSelector()
    stats = {'opened': 0, 'closed_by_server': 0, 'connect_failed': 0, 'slow_bytes': 0}
    conns = {}  # socket -> {'slow': bool, 'source': str, 'sent': int}
    head = b'POST /data HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nX-Slow: '
    stopping = []
    signal.signal(signal.SIGTERM, lambda *_: stopping.append(1))

    def open_one(source, slow):
        s = connect_from(source, a.port)
        if s is None:
            stats['connect_failed'] += 1
            return False
        stats['opened'] += 1
        conns[s] = {'slow': slow, 'source': source, 'sent': 0}
        sel.register(s, selectors.EVENT_READ)
        return True

    want = [(idle_from[i % len(idle_from)], False) for i in range(a.idle)] + \
           [(slow_from[i % len(slow_from)], True) for i in range(a.slow)]
    pending = list(want)  # to open (again)
    ready_written = False
    next_byte = time.monotonic() + a.byte_every
    while not stopping:
        while pending:
            source, slow = pending[-1]
            if not open_one(source, slow):
                break  # retried on the next turn
            pending.pop()
        if not ready_written and not pending:
            open(a.ready, 'w').write('%d\n' % len(conns))
            ready_written = True
        timeout = max(0.0, next_byte - time.monotonic())
        for key, _ in sel.select(timeout=min(timeout, 0.05) if not pending else 0.001):
            s = key.fileobj
            try:
                data = s.recv(4096)
            except OSError:
                data = b''
            if data:
                continue  # a 408 before the close
            info = conns.pop(s)
            sel.unregister(s)
            s.close()
            stats['closed_by_server'] += 1
            pending.append((info['source'], info['slow']))
        if time.monotonic() >= next_byte:
            next_byte += a.byte_every
            for s, info in list(conns.items()):
                if not info['slow']:
                    continue
                i = info['sent']
                byte = head[i:i + 1] if i < len(head) else b'a'
                try:
                    s.send(byte)
                    info['sent'] += 1
                    stats['slow_bytes'] += 1
                except OSError:
                    pass  # closed: seen by the selector
    json.dump(stats, open(a.stats, 'w'))
    return 0


def probe(a):
    body = open(a.body_file, 'rb').read() if a.body_file else None
    results = []
    start = time.monotonic()
    for k in range(a.count):
        due = start + k * a.every
        while time.monotonic() < due:  # pacing, so that the slowloris goes on meanwhile
            time.sleep(min(0.01, max(0.0, due - time.monotonic())))
        t0 = time.monotonic()
        status, text, error = 0, '', ''
        data = body.replace(b'@T@', b'%d' % (1698501144000000000 + (a.first + k) * 10000000)) \
            if body is not None else None
        try:
            s = socket.create_connection(('127.0.0.1', a.port), timeout=a.deadline,
                                         source_address=('127.0.0.1', 0))
            s.settimeout(max(0.001, a.deadline - (time.monotonic() - t0)))
            req = '%s %s HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n' % (a.method, a.path)
            if data is not None:
                req += 'Content-Type: application/json\r\nContent-Length: %d\r\n' % len(data)
            s.sendall(req.encode() + b'\r\n' + (data or b''))
            reply = b''
            while True:
                s.settimeout(max(0.001, a.deadline - (time.monotonic() - t0)))
                chunk = s.recv(65536)
                if not chunk:
                    break
                reply += chunk
            s.close()
            text = reply.decode('utf-8', 'replace')
            status = int(text[9:12]) if text.startswith('HTTP/1.') else 0
        except (OSError, ValueError) as e:
            error = repr(e)
        dt = time.monotonic() - t0
        ok = 200 <= status < 300 and dt <= a.deadline and a.expect in text
        results.append({'status': status, 'latency_s': round(dt, 4), 'ok': ok,
                        'error': error or (text[:200] if not ok else '')})
    lat = sorted(r['latency_s'] for r in results)
    summary = {'count': len(results), 'ok': sum(r['ok'] for r in results),
               'statuses': sorted({r['status'] for r in results}),
               'latency_median_s': lat[len(lat) // 2], 'latency_max_s': lat[-1],
               'failures': [r for r in results if not r['ok']][:5]}
    print(json.dumps(summary))
    if a.out:
        json.dump(summary, open(a.out, 'w'))
    if a.require and summary['ok'] != summary['count']:
        print('FAIL: %d of %d requests got no 2xx within %g s' %
              (summary['count'] - summary['ok'], summary['count'], a.deadline), file=sys.stderr)
        return 1
    return 0


def main():
    p = argparse.ArgumentParser()
    sub = p.add_subparsers(dest='cmd', required=True)
    at = sub.add_parser('attack')
    at.add_argument('port', type=int)
    at.add_argument('--ready', required=True)
    at.add_argument('--stats', required=True)
    at.add_argument('--idle', type=int, default=200)
    at.add_argument('--idle-from', default='127.0.0.2,127.0.0.3')
    at.add_argument('--slow', type=int, default=10)
    at.add_argument('--slow-from', default='127.0.0.4')
    at.add_argument('--byte-every', type=float, default=0.5)
    pr = sub.add_parser('probe')
    pr.add_argument('port', type=int)
    pr.add_argument('--method', default='GET')
    pr.add_argument('--path', default='/')
    pr.add_argument('--body-file')
    pr.add_argument('--count', type=int, default=20)
    pr.add_argument('--first', type=int, default=0)
    pr.add_argument('--every', type=float, default=0.2)
    pr.add_argument('--deadline', type=float, default=1.0)
    pr.add_argument('--expect', default='')
    pr.add_argument('--require', action='store_true')
    pr.add_argument('--out')
    a = p.parse_args()
    return attack(a) if a.cmd == 'attack' else probe(a)


if __name__ == '__main__':
    sys.exit(main())
