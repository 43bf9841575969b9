#!/usr/bin/env python3
"""scripts/soak's body: the lab on three machines for N minutes while the world misbehaves.

  soak.py run --bin DIR [--minutes N] [--profile FILE] [--seed S] [--work DIR] [--json FILE]
  soak.py serial-device LINK          (internal) a UWB tag on a pseudo-terminal
  soak.py anchor-server PORT RECORDS  (internal) the TDoA anchors' TCP server

Topology: four network namespaces. sensors, compute and recorder are the lab's machines (each
with its own hostname, veth eth0, LCM multicast with ttl=1); the fourth holds soak-switch, the LAN,
which spoils each link as the profile says (loss, duplication, delay, jitter, reordering: this
kernel has no sch_netem). Each machine runs `ips-deploy run` on its part of one deployment file;
the real lcm-logger on the recorder machine keeps the evidence. Faults follow a seeded schedule,
printed as they happen; at the end a report says, per fault, how long each process took to be OK
again, how long the fused accuracy took to be back under the lab bound, the estimates and messages
lost, and checks what docs/reliability.md promises. Exit status 0 when every check holds, 1 when
one fails, 2 for a usage or setup error (77: no network namespaces here).
"""
import argparse
import json
import math
import os
import random
import re
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, 'tests', 'integration'))
import lcm_log  # noqa: E402
import lcm_messages  # noqa: E402

GROUP, PORT = '239.255.76.67', 7667
URL = f'udpm://{GROUP}:{PORT}?ttl=1&recv_buf_size=4194304'
FAKETIME_LIB = '/usr/lib/x86_64-linux-gnu/faketime/libfaketime.so.1'
STATE_OK = 0
STATE_NAMES = {0: 'ok', 1: 'degraded', 2: 'error', 3: 'starting'}
SANITIZER = re.compile(r'AddressSanitizer|LeakSanitizer|UndefinedBehaviorSanitizer|runtime error:'
                       r'|ThreadSanitizer')

# The lab: what runs where. program: the command; args; kind: driver, estimator or recorder.
HOSTS = {
    'sensors': [
        ('sim', 'ips-sim', ['--scenario', 'lab', '--duration', '86400', '--log-level', 'warn'],
         'driver'),
        ('serial', 'ips-uwb-serial', ['--device', '@WORK@/ttySOAK', '--format', 'line', '--reopen-s',
                                      '0.5', '--channel', 'UWB_RANGE=SOAK_SERIAL_RANGE',
                                      '--log-level', 'warn'], 'driver'),
        ('anchors', 'ips-uwb-tdoa-anchors', ['--tcp', '127.0.0.1:47311', '@IDS@',
                                             '--reconnect-max-s', '1', '--channel',
                                             'UWB_RX=SOAK_TDOA_RX', '--log-level', 'warn'],
         'driver'),
    ],
    'compute': [
        ('uwb-twr', 'ips-uwb-twr', ['--log-level', 'warn'], 'estimator'),
        ('aoa', 'ips-aoa', ['--log-level', 'warn'], 'estimator'),
        ('fuse', 'ips-fuse', ['--log-level', 'warn'], 'estimator'),
        ('zones', 'ips-zones', ['--log-level', 'warn'], 'estimator'),
    ],
    'recorder': [
        ('record', 'ips-record', ['--site-wait', '0', '--min-free-mb', '1', '--log-level', 'warn'],
         'recorder'),
    ],
}
PROCS = {name: (host, prog, kind) for host, ps in HOSTS.items() for name, prog, _, kind in ps}


def log(msg):
    print(msg, flush=True)


def sh(*cmd, check=True, **kw):
    return subprocess.run(list(cmd), check=check, **kw)


# ------------------------------------------------------------------------------------------------
# The fake devices (run as subcommands in the sensors namespace).

def serial_device(link):
    """A UWB tag on a pty at LINK: RANGE lines for tag S1 and anchors A1..A4 at 20 lines/s.
    SIGUSR1 unplugs it (the master closed, the link removed); SIGUSR2 plugs a new pty in."""
    state = {'master': None, 'want': True}

    def plug():
        master, slave = os.openpty()
        name = os.ttyname(slave)
        os.set_blocking(master, False)
        tmp = link + '.new'
        if os.path.lexists(tmp):
            os.unlink(tmp)
        os.symlink(name, tmp)
        os.rename(tmp, link)
        os.close(slave)
        state['master'] = master

    def unplug():
        if state['master'] is not None:
            os.close(state['master'])
            state['master'] = None
        if os.path.lexists(link):
            os.unlink(link)

    signal.signal(signal.SIGUSR1, lambda *_: state.update(want=False))
    signal.signal(signal.SIGUSR2, lambda *_: state.update(want=True))
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    k = 0
    try:
        while True:
            if state['want'] and state['master'] is None:
                plug()
            elif not state['want'] and state['master'] is not None:
                unplug()
            if state['master'] is not None:
                line = f'RANGE S1 A{k % 4 + 1} {4.0 + 0.01 * (k % 50):.2f} -78.5\n'.encode()
                try:
                    os.write(state['master'], line)
                except OSError:
                    pass  # nobody has the slave open yet: the line is lost, as on a real port
                k += 1
            time.sleep(0.05)
    finally:
        unplug()


def anchor_server(port, records):
    """The TDoA anchors' server: sends RECORDS' lines, over and over, 50 a second, to one client at
    a time on 127.0.0.1:PORT."""
    lines = open(records, 'rb').read().splitlines(keepends=True)
    srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    srv.bind(('127.0.0.1', port))
    srv.listen(1)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    k = 0
    while True:
        conn, _ = srv.accept()
        try:
            while True:
                conn.sendall(lines[k % len(lines)])
                k += 1
                time.sleep(0.02)
        except OSError:
            conn.close()


# ------------------------------------------------------------------------------------------------
# The evidence: the real lcm-logger's log, read as it grows.

class Evidence:
    """Reads the evidence log incrementally: HEALTH per (source), TRUTH and POSE_FUSED per tag,
    and the first message of each channel (for its fingerprint)."""

    def __init__(self, path):
        self.path, self.offset, self.buf = path, 0, b''
        self.health = {}   # source -> [(t_s, dict)]
        self.truth = {}    # tag -> [(utime, x, y)]
        self.fused = {}    # tag -> [(utime, x, y, t_s)]
        self.first = {}    # channel -> data
        self.counts = {}   # channel -> messages

    def poll(self):
        try:
            with open(self.path, 'rb') as f:
                f.seek(self.offset)
                self.buf += f.read()
                self.offset = f.tell()
        except FileNotFoundError:
            return
        events, n = lcm_log.parse(self.buf)
        for ch, ts, payload in events:
            self.add(ch, ts / 1e6, payload)
        self.buf = self.buf[n:]
        # What is left is an event still being written, never a damaged one.
        if len(self.buf) >= 4 and struct.unpack('>I', self.buf[:4])[0] != lcm_log.MAGIC:
            raise RuntimeError(f'evidence log damaged at byte {self.offset - len(self.buf)}')

    def add(self, ch, t, payload):
        self.counts[ch] = self.counts.get(ch, 0) + 1
        self.first.setdefault(ch, payload)
        try:
            if ch == 'HEALTH':
                h = lcm_messages.health(payload)
                self.health.setdefault(h['source'], []).append((t, h))
            elif ch == 'TRUTH':
                p = lcm_messages.pose(payload)
                self.truth.setdefault(p['tag_id'], []).append((p['utime'], *p['position'][:2]))
            elif ch == 'POSE_FUSED':
                p = lcm_messages.pose(payload)
                self.fused.setdefault(p['tag_id'], []).append(
                    (p['utime'], *p['position'][:2], t))
        except (struct.error, IndexError):
            pass  # the soak's own malformed packets, recorded as they came

    def last_health(self, source):
        h = self.health.get(source)
        return h[-1] if h else None


# ------------------------------------------------------------------------------------------------
# The machines.

class Lab:
    def __init__(self, args, profile, work):
        self.profile, self.work = profile, work
        self.bin = args.bin
        self.ns = f'soak{os.getpid() % 100000}'
        self.children = []  # (name, Popen)
        self.hosts = list(HOSTS)
        self.deploy = {}
        self.disk = os.path.join(work, 'disk')
        self.records = os.path.join(work, 'records.txt')
        self.serial_link = os.path.join(work, 'ttySOAK')
        self.clock_file = os.path.join(work, 'clock.rc')

    def nsname(self, host):
        return f'{self.ns}-{host[0]}'

    def setup_network(self):
        sw = f'{self.ns}-w'
        if sh('ip', 'netns', 'add', sw, check=False, stderr=subprocess.DEVNULL).returncode != 0:
            log('SKIP: cannot create network namespaces here (needs root and iproute2)')
            sys.exit(77)
        sh('ip', '-n', sw, 'link', 'set', 'lo', 'up')
        for i, host in enumerate(self.hosts, start=1):
            n = self.nsname(host)
            sh('ip', 'netns', 'add', n)
            sh('ip', 'link', 'add', 'name', 'eth0', 'netns', n, 'type', 'veth', 'peer', 'name',
               f'port-{host}', 'netns', sw)
            sh('ip', '-n', sw, 'link', 'set', f'port-{host}', 'up')
            sh('ip', '-n', sw, 'addr', 'add', f'10.79.0.{100 + i}/24', 'dev', f'port-{host}')
            sh('ip', '-n', n, 'link', 'set', 'lo', 'up')
            sh('ip', '-n', n, 'link', 'set', 'lo', 'multicast', 'on')
            sh('ip', '-n', n, 'addr', 'add', f'10.79.0.{i}/24', 'dev', 'eth0')
            sh('ip', '-n', n, 'link', 'set', 'eth0', 'up')
            sh('ip', '-n', n, 'route', 'add', '224.0.0.0/4', 'dev', 'eth0')

    def teardown(self):
        for _, p in reversed(self.children):
            if p.poll() is None:
                try:
                    p.send_signal(signal.SIGINT)
                except ProcessLookupError:
                    pass
        deadline = time.monotonic() + 15
        for _, p in self.children:
            try:
                p.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                p.kill()
        for host in self.hosts + ['w']:
            n = self.nsname(host) if host != 'w' else f'{self.ns}-w'
            out = sh('ip', 'netns', 'pids', n, check=False, capture_output=True, text=True)
            for pid in out.stdout.split():
                try:
                    os.kill(int(pid), signal.SIGKILL)
                except (ProcessLookupError, ValueError):
                    pass
            sh('ip', 'netns', 'del', n, check=False, stderr=subprocess.DEVNULL)

    def start(self, name, host, cmd, out, env=None, hostname=None):
        n = self.nsname(host) if host != 'switch' else f'{self.ns}-w'
        full = ['ip', 'netns', 'exec', n]
        if hostname:
            full += ['unshare', '--uts', 'sh', '-c', 'hostname "$0"; exec "$@"', hostname]
        full += cmd
        e = dict(os.environ)
        e.update(env or {})
        p = subprocess.Popen(full, stdout=open(out, 'w'), stderr=subprocess.STDOUT, env=e,
                             start_new_session=True)
        self.children.append((name, p))
        return p

    def pids(self, host, program):
        """Pids of PROGRAM running on HOST (from the namespace's processes)."""
        out = sh('ip', 'netns', 'pids', self.nsname(host), check=False, capture_output=True,
                 text=True).stdout.split()
        found = []
        for pid in out:
            try:
                argv0 = open(f'/proc/{pid}/cmdline', 'rb').read().split(b'\0')[0].decode()
            except OSError:
                continue
            if os.path.basename(argv0) == program:
                found.append(int(pid))
        return found

    def deployment(self, ids):
        lines = [
            'name: soak', f'lcm_url: "{URL}"', f'bin_dir: {self.bin}',
            f'working_dir: {self.work}',
            'restart: {initial_s: 0.5, max_s: 2, reset_after_s: 5}', 'stop_timeout_s: 3',
            'environment: {TZ: UTC}', 'hosts:']
        clock_target = self.profile['clock_target']
        for host, procs in HOSTS.items():
            lines += [f'  - name: {host}', f'    hostname: soak-{host}', '    processes:']
            for name, prog, args, _ in procs:
                a = []
                for x in args:
                    if x == '@IDS@':
                        a += ids
                    else:
                        a.append(x.replace('@WORK@', self.work))
                lines += [f'      - name: {name}', f'        command: {prog}',
                          f'        args: {json.dumps(a)}', '        restart: always']
                if name == clock_target:
                    env = {'LD_PRELOAD': FAKETIME_LIB, 'FAKETIME_TIMESTAMP_FILE': self.clock_file,
                           'FAKETIME_DONT_FAKE_MONOTONIC': '1', 'FAKETIME_CACHE_DURATION': '1',
                           'ASAN_OPTIONS': 'verify_asan_link_order=0:'
                                           + os.environ.get('ASAN_OPTIONS', '')}
                    lines.append(f'        environment: {json.dumps(env)}')
        path = os.path.join(self.work, 'soak.yaml')
        open(path, 'w').write('\n'.join(lines) + '\n')
        return path


# ------------------------------------------------------------------------------------------------
# Faults.

def lcm_packet(seq, channel, payload):
    return struct.pack('>II', 0x4C433032, seq) + channel.encode() + b'\0' + payload


def uwb_range_payload(fingerprint, seq, anchor):
    def s(x):
        b = x.encode() + b'\0'
        return struct.pack('>i', len(b)) + b
    return (fingerprint + struct.pack('>q', int(time.time() * 1e6)) + s('soak-load') + s('L1')
            + s(anchor) + struct.pack('>dfffi', 5.0, -80.0, -82.0, 1.0, seq))


def paced_send(ns, ttl, rate, seconds, kind, fingerprints, out):
    """Runs this file's `send` subcommand in namespace NS; returns the Popen."""
    cmd = ['ip', 'netns', 'exec', ns, sys.executable, os.path.abspath(__file__), 'send',
           '--ttl', str(ttl), '--rate', str(rate), '--seconds', str(seconds), '--kind', kind,
           '--fingerprints', json.dumps({k: v.hex() for k, v in fingerprints.items()})]
    return subprocess.Popen(cmd, stdout=open(out, 'w'), stderr=subprocess.STDOUT)


def send_main(a):
    """The flood, the malformed packets and the load, paced in bursts every 10 ms; prints JSON of
    what was sent."""
    fps = {k: bytes.fromhex(v) for k, v in json.loads(a.fingerprints).items()}
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, a.ttl)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 4 << 20)
    rng = random.Random(7)
    real = [c for c in ('UWB_RANGE', 'BLE_AOA', 'IMU', 'POSE_UWB', 'POSE_FUSED', 'SITE', 'HEALTH',
                        'TRUTH') if c in fps]
    sent, failed, seq = 0, 0, 0
    t0 = time.monotonic()
    end = t0 + a.seconds
    while True:
        now = time.monotonic()
        if now >= end:
            break
        due = int((now - t0) * a.rate)
        while sent + failed < due:
            if a.kind == 'flood':
                pkt = lcm_packet(seq, 'SOAK_FLOOD', b'\x00' * 8 + struct.pack('>q', seq))
            elif a.kind == 'load':
                # One sender key (tag L1, anchor LA): its numbers run 0, 1, 2, ... so that the
                # receivers' sequence loss counters see exactly what went missing.
                pkt = lcm_packet(seq, 'SOAK_LOAD', uwb_range_payload(fps['UWB_RANGE'], seq, 'LA'))
            else:  # malformed: a real channel, and a payload that is not what it should be
                ch = real[seq % len(real)]
                kind = seq % 4
                good = fps[ch]
                if kind == 0:
                    payload = bytes(rng.getrandbits(8) for _ in range(40))       # no fingerprint
                elif kind == 1:
                    payload = good[:8] + bytes(rng.getrandbits(8) for _ in range(6))  # cut short
                elif kind == 2:
                    payload = good[:8] + struct.pack('>q', 1) + struct.pack('>i', 0x7FFFFFF0)
                else:
                    payload = b''
                pkt = lcm_packet(seq, ch, payload)
                if seq % 16 == 15:
                    pkt = b'LC03' + pkt[4:30]  # a fragment of nothing
            try:
                s.sendto(pkt, (GROUP, PORT))
                sent += 1
            except OSError:
                failed += 1
            seq += 1
        time.sleep(0.01)
    print(json.dumps({'kind': a.kind, 'sent': sent, 'failed': failed,
                      'seconds': time.monotonic() - t0}))


# ------------------------------------------------------------------------------------------------
# The run.

def schedule(profile, seed, t_begin, t_end):
    """The faults, seeded: one of each kind first (targets drawn), then every (kind, target) pair
    in a seeded order, over and over, as long as there is time."""
    rng = random.Random(seed)
    procs = sorted(PROCS)
    estimators = sorted(n for n, (_, _, k) in PROCS.items() if k == 'estimator')
    pairs = ([('kill', p) for p in procs] + [('term', p) for p in procs]
             + [('stop', p) for p in estimators]
             + [('unplug', 'serial'), ('server', 'anchors'), ('disk', 'record'),
                ('clock', profile['clock_target']), ('flood', 'compute'),
                ('malformed', 'compute')])
    pairs = [p for p in pairs if p[0] in profile['faults']]
    kinds = sorted({k for k, _ in pairs})
    first = [(k, rng.choice([t for kk, t in pairs if kk == k])) for k in kinds]
    # The recorder's and the fusion's deaths have checks of their own (the log to its last whole
    # event, the accuracy after a restart): in the first round whatever the draw.
    for must in (('kill', 'record'), ('kill', 'fuse')):
        if must in pairs and must not in first:
            first.append(must)
    rng.shuffle(first)
    out, t = [], t_begin
    order = list(first)
    while True:
        if not order:
            order = list(pairs)
            rng.shuffle(order)
        kind, target = order.pop(0)
        length = profile['durations'].get(kind, 0) + profile['gap_s']
        if t + length > t_end:
            break
        out.append({'kind': kind, 'target': target, 'at': t})
        t += length
    return out


def wait_until(pred, timeout, evidence, what):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        evidence.poll()
        r = pred()
        if r:
            return r
        time.sleep(0.2)
    raise SystemExit(f'soak: timed out after {timeout:.0f} s waiting for {what}')


class Run:
    def __init__(self, args, profile):
        self.args, self.profile = args, profile
        self.work = args.work or tempfile.mkdtemp(prefix='soak-')
        os.makedirs(self.work, exist_ok=True)
        self.lab = Lab(args, profile, self.work)
        self.ev = Evidence(os.path.join(self.work, 'evidence.lcm'))
        self.faults = []
        self.t0 = None
        self.device = None
        self.server = None
        self.fingerprints = {}

    def stamp(self):
        return f'[{time.time() - self.t0:7.1f} s]'

    def start_server(self):
        self.server = self.lab.start('anchor-server', 'sensors',
                                     [sys.executable, os.path.abspath(__file__), 'anchor-server',
                                      '47311', self.lab.records],
                                     os.path.join(self.work, 'anchor-server.out'))

    def setup(self):
        lab, work = self.lab, self.work
        # The recorder's disk: a small tmpfs (this process runs in its own mount namespace).
        os.makedirs(lab.disk, exist_ok=True)
        size = int(self.profile['disk_mb'] + 12 * self.args.minutes)
        sh('mount', '-t', 'tmpfs', '-o', f'size={size}m', 'tmpfs', lab.disk)
        open(lab.clock_file, 'w').write('+0\n')
        # The anchors' records: a simulated TDoA hall as the wire's records.
        sim_log = os.path.join(work, 'tdoa.lcm')
        sh(os.path.join(lab.bin, 'ips-sim'), '--scenario', 'tdoa-hall', '--duration', '20',
           '--out', sim_log, '--log-level', 'warn')
        r = subprocess.run([os.path.join(lab.bin, 'ips-uwb-tdoa-anchors'), '--to-records', sim_log],
                           stdout=open(lab.records, 'w'), stderr=subprocess.PIPE, text=True,
                           check=True)
        ids = re.findall(r'--id [0-9a-f]{4}=[A-Za-z0-9]+', r.stderr)
        if not ids:
            raise SystemExit(f'soak: --to-records gave no --id options: {r.stderr}')
        ids = [w for i in ids for w in i.split()]
        path = lab.deployment(ids)
        sh(os.path.join(lab.bin, 'ips-deploy'), 'check', path, stdout=subprocess.DEVNULL)
        lab.setup_network()
        # The LAN.
        links = self.profile['links']
        ports = []
        for host in lab.hosts:
            f = links.get(host, {})
            ports += ['--port', ','.join([f'port-{host}'] + [f'{k}={v}' for k, v in f.items()])]
        lab.start('switch', 'switch', [os.path.join(lab.bin, 'soak-switch'), '--seed',
                                       str(self.args.seed), '--stats',
                                       os.path.join(work, 'switch.json')] + ports,
                  os.path.join(work, 'switch.out'))
        # The evidence: the real lcm-logger on the recorder machine (its link is delayed, never
        # lossy), on a disk of its own.
        lab.start('lcm-logger', 'recorder', ['lcm-logger', '-q', '-f', self.ev.path],
                  os.path.join(work, 'lcm-logger.out'),
                  env={'LCM_DEFAULT_URL': URL.replace('4194304', '8388608')})
        # The devices.
        self.device = lab.start('serial-device', 'sensors',
                                [sys.executable, os.path.abspath(__file__), 'serial-device',
                                 lab.serial_link], os.path.join(work, 'serial-device.out'))
        self.start_server()
        self.t0 = time.time()
        for host in ('recorder', 'compute', 'sensors'):
            wd = ['--working-dir', lab.disk] if host == 'recorder' else []
            lab.deploy[host] = lab.start(
                f'deploy-{host}', host, [os.path.join(lab.bin, 'ips-deploy'), 'run', path,
                                         '--host', host] + wd,
                os.path.join(work, f'deploy-{host}.out'), hostname=f'soak-{host}')
        log(f'{self.stamp()} the lab is starting: {path}; evidence {self.ev.path}')

        def all_ok():
            for name, (host, prog, _) in PROCS.items():
                h = self.ev.last_health(prog)
                if h is None or h[1]['state'] != STATE_OK:
                    return None
            return True
        try:
            wait_until(all_ok, 120, self.ev, 'every process OK')
        except SystemExit:
            states = {prog: (STATE_NAMES.get(self.ev.last_health(prog)[1]['state'])
                             if self.ev.last_health(prog) else 'not heard')
                      for _, (_, prog, _) in PROCS.items()}
            raise SystemExit(f'soak: the lab did not come up OK within 120 s: {states}')
        self.fingerprints = {ch: d[:8] for ch, d in self.ev.first.items() if len(d) >= 8}
        log(f'{self.stamp()} every process OK')

    # -- the faults --------------------------------------------------------------------------
    def signal_proc(self, target, sig):
        host, prog, _ = PROCS[target]
        pids = self.lab.pids(host, prog)
        for pid in pids:
            os.kill(pid, sig)
        return pids

    def do_fault(self, f):
        kind, target = f['kind'], f['target']
        d = self.profile['durations'].get(kind, 0)
        f['start'] = time.time()
        if kind in ('kill', 'term'):
            pids = self.signal_proc(target, signal.SIGKILL if kind == 'kill' else signal.SIGTERM)
            f['pids'] = pids
            what = f'{"SIGKILL" if kind == "kill" else "SIGTERM"} {target} (pid {pids})'
            if target == 'record' and kind == 'kill':
                f['files'] = sorted(os.listdir(self.lab.disk))
        elif kind == 'stop':
            pids = self.signal_proc(target, signal.SIGSTOP)
            f['pids'] = pids
            log(f'{self.stamp()} SIGSTOP {target} (pid {pids}) for {d} s')
            time.sleep(d)
            self.signal_proc(target, signal.SIGCONT)
            what = f'SIGCONT {target}'
        elif kind == 'unplug':
            self.device.send_signal(signal.SIGUSR1)
            log(f'{self.stamp()} serial device unplugged for {d} s')
            time.sleep(d)
            self.device.send_signal(signal.SIGUSR2)
            what = 'serial device plugged in again'
        elif kind == 'server':
            self.server.kill()
            self.server.wait()
            log(f'{self.stamp()} the anchors\' TCP server is gone for {d} s')
            time.sleep(d)
            self.start_server()
            what = 'the anchors\' TCP server is back'
        elif kind == 'disk':
            filler = os.path.join(self.lab.disk, 'filler')
            with open(filler, 'wb') as out:
                chunk = b'\0' * (1 << 20)
                try:
                    while True:
                        out.write(chunk)
                        out.flush()
                except OSError:
                    pass
            log(f'{self.stamp()} the recorder\'s disk is full for {d} s')
            time.sleep(d)
            os.unlink(filler)
            what = 'the recorder\'s disk has room again'
        elif kind == 'clock':
            step = self.profile['clock_step_s']
            open(self.lab.clock_file, 'w').write(f'+{step}\n')
            log(f'{self.stamp()} {target}\'s clock stepped +{step} s for {d} s')
            time.sleep(d)
            open(self.lab.clock_file, 'w').write('+0\n')
            what = f'{target}\'s clock stepped back -{step} s'
        elif kind in ('flood', 'malformed'):
            rate = self.profile['flood_rate'] if kind == 'flood' else self.profile['malformed_rate']
            p = paced_send(self.lab.nsname('compute'), 0, rate, d, kind, self.fingerprints,
                           os.path.join(self.work, f'{kind}-{len(self.faults)}.json'))
            log(f'{self.stamp()} {kind}: {rate}/s on compute for {d} s')
            p.wait(d + 60)
            sent = json.load(open(os.path.join(self.work, f'{kind}-{len(self.faults)}.json')))
            f['sent'] = sent
            what = f'{kind} over: {sent["sent"]} sent in {sent["seconds"]:.1f} s'
        else:
            raise ValueError(kind)
        f['end'] = time.time()
        log(f'{self.stamp()} fault {len(self.faults) + 1}: {what}')
        self.faults.append(f)

    def load_phase(self):
        """The recorder at load_factor x the lab's load: the lab's own rate, measured, plus
        SOAK_LOAD messages (uwb_range_t, numbered) from compute across the switch."""
        ev = self.ev
        ev.poll()
        span = max(1.0, time.time() - self.t0)
        lab_rate = sum(n for ch, n in ev.counts.items() if not ch.startswith('SOAK_F')) / span
        extra = lab_rate * (self.profile['load_factor'] - 1)
        secs = self.profile['load_s']
        out = os.path.join(self.work, 'load.json')
        log(f'{self.stamp()} load: the lab sends {lab_rate:.0f} messages/s; '
            f'{extra:.0f}/s more for {secs} s ({self.profile["load_factor"]}x)')
        p = paced_send(self.lab.nsname('compute'), 1, int(extra), secs, 'load', self.fingerprints,
                       out)
        p.wait(secs + 60)
        self.load = json.load(open(out))
        self.load['lab_rate'] = lab_rate
        self.load['factor'] = self.profile['load_factor']
        log(f'{self.stamp()} load: {self.load["sent"]} SOAK_LOAD messages sent')

    def run(self):
        self.setup()
        begin = time.time() + self.profile['warmup_s']
        end = self.t0 + self.args.minutes * 60 - self.profile['load_s'] - 15
        plan = schedule(self.profile, self.args.seed, begin, end)
        log(f'{self.stamp()} {len(plan)} faults planned (seed {self.args.seed}): '
            + ', '.join(f'{p["kind"]}:{p["target"]}' for p in plan))
        for f in plan:
            while time.time() < f['at']:
                self.ev.poll()
                time.sleep(min(0.5, max(0.0, f['at'] - time.time())))
            self.do_fault(f)
        # The tail of the last fault's recovery, then the load.
        t = time.time() + self.profile['gap_s']
        while time.time() < t:
            self.ev.poll()
            time.sleep(0.5)
        self.load_phase()
        t = time.time() + 5
        while time.time() < t:
            self.ev.poll()
            time.sleep(0.5)
        self.stop()
        return Report(self).check()

    def stop(self):
        lab = self.lab
        for host in HOSTS:
            p = lab.deploy[host]
            p.send_signal(signal.SIGINT)
        for host in HOSTS:
            try:
                lab.deploy[host].wait(30)
            except subprocess.TimeoutExpired:
                lab.deploy[host].kill()
        time.sleep(1.0)  # the logger's last flush (it flushes every 100 ms)
        self.ev.poll()


# ------------------------------------------------------------------------------------------------
# The report.

def interp(series, u):
    """(x, y) of SERIES [(utime, x, y)] sorted, at utime u; None outside it or across a gap > 1 s."""
    import bisect
    i = bisect.bisect_left(series, (u,))
    if i == 0 or i >= len(series):
        return None
    (u0, x0, y0), (u1, x1, y1) = series[i - 1], series[i]
    if u1 - u0 > 1_000_000:
        return None
    w = (u - u0) / (u1 - u0) if u1 > u0 else 0.0
    return x0 + w * (x1 - x0), y0 + w * (y1 - y0)


def p95(v):
    if not v:
        return math.nan
    s = sorted(v)
    return s[min(len(s) - 1, int(math.ceil(0.95 * len(s))) - 1)]


class Report:
    def __init__(self, run):
        self.run, self.ev, self.p = run, run.ev, run.profile
        self.fail = []
        self.rows = []
        for tag in self.ev.truth:
            self.ev.truth[tag].sort()
        # Fused errors: (receive time, horizontal error) per estimate.
        self.errors = []
        for tag, est in self.ev.fused.items():
            truth = self.ev.truth.get(tag, [])
            for u, x, y, t in est:
                xy = interp(truth, u)
                if xy is not None:
                    self.errors.append((t, math.hypot(x - xy[0], y - xy[1]), tag))
        self.errors.sort()

    def window(self, a, b):
        import bisect
        i = bisect.bisect_left(self.errors, (a,))
        j = bisect.bisect_left(self.errors, (b,))
        return [e[1] for e in self.errors[i:j]]

    def ok_after(self, prog, t, old_pids=()):
        """First time >= t when PROG's HEALTH said OK (from a pid not in OLD_PIDS)."""
        for ts, h in self.ev.health.get(prog, []):
            if ts >= t and h['state'] == STATE_OK and h['pid'] not in old_pids:
                return ts
        return None

    def accuracy_back(self, t):
        """First time >= t from which the fused estimates of the next 2 s meet the lab bound."""
        bound, win = self.p['p95_h_m'], 2.0
        k = 0.0
        while k <= 20.0:
            e = self.window(t + k, t + k + win)
            if len(e) >= 5 and p95(e) <= bound:
                return t + k
            k += 0.1
        return None

    def affected(self, f):
        """The processes a fault is meant to disturb, as (program, old pids)."""
        kind, target = f['kind'], f['target']
        if kind in ('flood', 'malformed'):
            return [(prog, ()) for name, (host, prog, _) in PROCS.items() if host == 'compute']
        prog = PROCS[target][1]
        return [(prog, tuple(f.get('pids', ())) if kind in ('kill', 'term') else ())]

    def check(self):
        ev, p = self.ev, self.p
        lim_ok, lim_acc = p['recover_s'], p['accuracy_s']
        log('')
        log('== soak report ==')
        log(f'{"fault":<34} {"ok again":>10} {"accuracy":>9} {"p95 before":>10} '
            f'{"p95 after":>9} {"est. lost":>9}')
        for n, f in enumerate(self.run.faults, 1):
            te = f['end']
            worst = 0.0
            notes = []
            for prog, old in self.affected(f):
                t_ok = self.ok_after(prog, te, old)
                if t_ok is None:
                    self.fail.append(f'fault {n} ({f["kind"]} {f["target"]}): {prog} never OK '
                                     f'again')
                    worst = math.inf
                    continue
                dt = max(0.0, t_ok - te)
                worst = max(worst, dt)
                if dt > lim_ok:
                    notes.append(f'{prog} {dt:.1f} s')
            if notes:
                self.fail.append(f'fault {n} ({f["kind"]} {f["target"]}): OK again only after '
                                 f'{", ".join(notes)} (bound {lim_ok} s)')
            before = p95(self.window(f['start'] - 10, f['start']))
            t_acc = self.accuracy_back(te)
            acc = math.inf if t_acc is None else max(0.0, t_acc - te)
            if acc > lim_acc:
                self.fail.append(f'fault {n} ({f["kind"]} {f["target"]}): fused accuracy back '
                                 f'under p95 {p["p95_h_m"]} m only after {acc:.1f} s '
                                 f'(bound {lim_acc} s)')
            after = p95(self.window(te + lim_acc, te + lim_acc + 5))
            lost = self.estimates_lost(f['start'], te + lim_acc)
            f.update(ok_again_s=worst, accuracy_back_s=acc, p95_before=before, p95_after=after,
                     estimates_lost=lost)
            log(f'{n:>2} {f["kind"] + " " + f["target"]:<31} {worst:>9.1f}s {acc:>8.1f}s '
                f'{before:>9.3f}m {after:>8.3f}m {lost:>9}')
        self.check_crashes()
        self.check_recorder()
        self.check_load()
        self.check_loss()
        overall = self.window(self.run.t0, time.time())
        log(f'fused accuracy over the whole run: {len(overall)} estimates, p95 '
            f'{p95(overall):.3f} m')
        if self.fail:
            log('')
            for x in self.fail:
                log(f'FAIL: {x}')
            log(f'soak: FAILED ({len(self.fail)} checks; logs in {self.run.work})')
        else:
            log(f'soak: passed ({len(self.run.faults)} faults)')
        if self.run.args.json:
            json.dump({'faults': self.run.faults, 'fail': self.fail,
                       'load': getattr(self.run, 'load', None), 'loss': self.loss},
                      open(self.run.args.json, 'w'), indent=1, default=str)
        return 1 if self.fail else 0

    def estimates_lost(self, a, b):
        """Fused estimates missing in [a, b]: per tag, the rate of the 10 s before times the span,
        less what came."""
        lost = 0
        for tag, est in self.ev.fused.items():
            ts = [e[3] for e in est]
            before = sum(1 for t in ts if a - 10 <= t < a) / 10.0
            got = sum(1 for t in ts if a <= t < b)
            lost += max(0, int(round(before * (b - a) - got)))
        return lost

    def check_crashes(self):
        failed_before = len(self.fail)
        for host in HOSTS:
            text = open(os.path.join(self.run.work, f'deploy-{host}.out'), errors='replace').read()
            for m in re.finditer(r'(\S+) exited with signal \d+ \((\w+)\)', text):
                if m.group(2) not in ('SIGKILL', 'SIGTERM', 'SIGINT'):
                    self.fail.append(f'{host}: {m.group(1)} crashed ({m.group(2)})')
            if report := SANITIZER.search(text):
                self.fail.append(f'{host}: a sanitizer report: '
                                 f'{text[report.start():report.start() + 200]!r}')
            # A process that ends by itself ends with 0 (SIGTERM, SIGINT); anything else failed.
            for m in re.finditer(r'(\S+) exited with status (\d+)', text):
                if m.group(2) not in ('0',):
                    self.fail.append(f'{host}: {m.group(1)} exited with status {m.group(2)}')
        log('crashes: ' + ('none' if len(self.fail) == failed_before else 'see FAIL lines'))

    def check_recorder(self):
        disk = self.run.lab.disk
        files = sorted(f for f in os.listdir(disk) if f.endswith('.lcm'))
        whole = 0
        for name in files:
            events, read, size = lcm_log.events(os.path.join(disk, name))
            rest = size - read
            if rest:
                # Only a last event cut short may remain (a SIGKILL or a full disk).
                data = open(os.path.join(disk, name), 'rb').read()[read:]
                cut = len(data) < 28 or (struct.unpack('>I', data[:4])[0] == lcm_log.MAGIC and
                                         28 + sum(struct.unpack('>II', data[20:28])) > len(data))
                if not cut:
                    self.fail.append(f'recorder: {name} is damaged at byte {read} of {size}')
            whole += len(events)
        log(f'recorder: {len(files)} files, {whole} whole events')
        for f in self.run.faults:
            if f['kind'] != 'disk':
                continue
            said = [h for ts, h in self.ev.health.get('ips-record', [])
                    if f['start'] <= ts <= f['end'] + 2 and 'disk' in h['last_error']]
            if not said:
                self.fail.append('recorder: HEALTH never said the disk was full')
            else:
                log(f'recorder: disk full said in HEALTH: "{said[-1]["last_error"][:120]}"')

    def check_load(self):
        load = getattr(self.run, 'load', None)
        if not load:
            return
        seqs = set()
        disk = self.run.lab.disk
        for name in sorted(os.listdir(disk)):
            if not name.endswith('.lcm'):
                continue
            for ch, _, data in lcm_log.events(os.path.join(disk, name))[0]:
                if ch == 'SOAK_LOAD':
                    seqs.add(lcm_messages.uwb_range(data)['seq'])
        missing = load['sent'] - len(seqs & set(range(load['sent'])))
        log(f'recorder at {load["factor"]}x the lab\'s load ({load["lab_rate"]:.0f} + '
            f'{load["sent"] / max(load["seconds"], 1e-9):.0f} messages/s): '
            f'{load["sent"]} sent, {missing} missing from its log')
        if missing:
            self.fail.append(f'recorder: lost {missing} of {load["sent"]} messages at '
                             f'{load["factor"]}x load')

    def check_loss(self):
        sw = json.load(open(os.path.join(self.run.work, 'switch.json')))['ports']
        self.loss = {'switch': sw}
        on_purpose = {h: sw[f'port-{h}']['lost'] for h in HOSTS}
        unwanted = {h: sw[f'port-{h}']['queue_full'] + sw[f'port-{h}']['send_failed']
                    for h in HOSTS}
        log(f'switch: copies lost on purpose per egress port {on_purpose}; '
            f'dropped otherwise {unwanted}')
        # What the processes counted: the last HEALTH of each pid, summed per program.
        for prog in sorted({p for _, p, _ in PROCS.values()}):
            per_pid = {}
            for _, h in self.ev.health.get(prog, []):
                per_pid[h['pid']] = h
            tot = {k: sum(h[k] for h in per_pid.values())
                   for k in ('seq_lost', 'kernel_drops', 'queue_drops', 'parse_errors', 'drops')}
            self.loss[prog] = tot
            log(f'{prog:<22} ' + ', '.join(f'{k} {v}' for k, v in tot.items()))


# ------------------------------------------------------------------------------------------------

def default_profile():
    return os.path.join(HERE, 'profiles', 'ci.json')


def main():
    ap = argparse.ArgumentParser(prog='scripts/soak', description=__doc__.split('\n\n')[0])
    sub = ap.add_subparsers(dest='cmd', required=True)
    r = sub.add_parser('run')
    r.add_argument('--bin', required=True)
    r.add_argument('--minutes', type=float, default=3.0)
    r.add_argument('--profile', default=default_profile())
    r.add_argument('--seed', type=int, default=1)
    r.add_argument('--work')
    r.add_argument('--json')
    s = sub.add_parser('serial-device')
    s.add_argument('link')
    a = sub.add_parser('anchor-server')
    a.add_argument('port', type=int)
    a.add_argument('records')
    se = sub.add_parser('send')
    se.add_argument('--ttl', type=int, required=True)
    se.add_argument('--rate', type=int, required=True)
    se.add_argument('--seconds', type=float, required=True)
    se.add_argument('--kind', required=True)
    se.add_argument('--fingerprints', required=True)
    args = ap.parse_args()
    if args.cmd == 'serial-device':
        return serial_device(args.link)
    if args.cmd == 'anchor-server':
        return anchor_server(args.port, args.records)
    if args.cmd == 'send':
        return send_main(args)
    args.bin = os.path.abspath(args.bin)
    try:
        profile = json.load(open(args.profile))
    except (OSError, ValueError) as e:
        print(f'soak: cannot read the profile {args.profile}: {e}', file=sys.stderr)
        return 2
    if args.minutes < 2:
        print('soak: --minutes must be at least 2', file=sys.stderr)
        return 2
    if 'clock' in profile['faults'] and not os.path.exists(FAKETIME_LIB):
        print(f'soak: {FAKETIME_LIB} is missing (Debian package faketime; scripts/install-deps)',
              file=sys.stderr)
        return 2
    for prog in ['soak-switch', 'ips-deploy', 'ips-sim'] + [p for _, p, _ in PROCS.values()]:
        if not os.access(os.path.join(args.bin, prog), os.X_OK):
            print(f'soak: no {prog} in {args.bin}', file=sys.stderr)
            return 2
    run = Run(args, profile)
    log(f'soak: {args.minutes:g} minutes, profile {args.profile}, seed {args.seed}, '
        f'work {run.work}')
    try:
        return run.run()
    finally:
        run.lab.teardown()


if __name__ == '__main__':
    sys.exit(main())
