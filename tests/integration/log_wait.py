#!/usr/bin/env python3
"""Waits until an LCM log being written (by lcm-logger or ips-record) holds what a live test is
about to check, instead of sleeping a fixed time that a loaded machine can overrun. Polls every
50 ms; exits 0 as soon as the condition holds, 1 with "FAIL: ..." after --timeout seconds, or at
once when the process --pid (the writer or the producer) has exited.

  log_wait.py LOG... --reach CHANNEL --end-after-site D [--site-log REF] [--slack S]
      an event on CHANNEL whose message time (utime, the first field of every ips type) is at
      least the end of the simulation less S seconds (default 1): the end is the first SITE's
      utime in REF (default: the LOG) plus D seconds (the scenario's duration). This is how a
      test knows a live estimator has caught up with everything the simulator published.
      With --or-idle NAME it also ends once process NAME has handled no message between two of
      its HEALTH reports logged after the wait began (msgs_in unchanged): it has taken all it
      will, even when the bus lost the last inputs (UDP under load) and no estimate reaches
      the end.
  log_wait.py LOG... --last-of REF
      the last event of REF that is not HEALTH, the same channel and bytes: a recorder has
      written everything a simulator published (REF: the same run written to a file).
  log_wait.py LOG... --events N
      at least N complete events.
LOG may be a glob pattern (quote it), matched again at each poll: ips-record's parts.
"""
import argparse
import glob
import os
import struct
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import lcm_log  # noqa: E402
import lcm_messages  # noqa: E402


def utime(data):
    # An LCM message is an 8-byte fingerprint, then the fields: every ips type but anchor_t,
    # baro_station_t and tag_t (which are only nested) starts with int64 utime.
    return struct.unpack('>q', data[8:16])[0] if len(data) >= 16 else None


class Reader:
    """The complete events of files that grow, each byte read once (a log can be many MB):
    poll() returns the events written since the last call."""

    def __init__(self, patterns):
        self.patterns, self.offsets = patterns, {}

    def poll(self):
        new = []
        for path in sorted({p for pat in self.patterns for p in glob.glob(pat)}):
            with open(path, 'rb') as f:
                f.seek(self.offsets.get(path, 0))
                data = f.read()
            i = 0
            while i + 28 <= len(data):
                magic, _, ts, cl, dl = struct.unpack('>IqqII', data[i:i + 28])
                if magic != lcm_log.MAGIC or i + 28 + cl + dl > len(data):
                    break  # not written yet (or damaged: then the wait times out)
                new.append((data[i + 28:i + 28 + cl].decode('latin-1'), ts,
                            data[i + 28 + cl:i + 28 + cl + dl]))
                i += 28 + cl + dl
            self.offsets[path] = self.offsets.get(path, 0) + i
        return new


def alive(pid):
    try:
        with open(f'/proc/{pid}/stat') as f:
            return f.read().rsplit(')', 1)[1].split()[0] != 'Z'
    except OSError:
        return False


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('log', nargs='+')
    p.add_argument('--reach')
    p.add_argument('--end-after-site', type=float)
    p.add_argument('--site-log')
    p.add_argument('--slack', type=float, default=1.0)
    p.add_argument('--or-idle')
    p.add_argument('--last-of')
    p.add_argument('--events', type=int)
    p.add_argument('--pid', type=int)
    p.add_argument('--timeout', type=float, default=60)
    a = p.parse_args()
    if sum(x is not None for x in (a.reach, a.last_of, a.events)) != 1 or \
            (a.reach is not None) != (a.end_after_site is not None):
        p.error('give one of --reach CHANNEL --end-after-site D, --last-of REF, --events N')

    end = last = None
    if a.site_log:
        sites = [e for e in lcm_log.events(a.site_log)[0] if e[0] == 'SITE']
        if not sites:
            sys.exit(f'FAIL: {a.site_log} has no SITE message')
        end = utime(sites[0][2]) + round((a.end_after_site - a.slack) * 1e6)
    if a.last_of:
        ref = [(c, d) for c, _, d in lcm_log.events(a.last_of)[0] if c != 'HEALTH']
        if not ref:
            sys.exit(f'FAIL: {a.last_of} has no event')
        last = ref[-1]

    t0 = time.time()
    deadline = t0 + a.timeout
    reader = Reader(a.log)
    count = reached = polls = 0
    newest = idle_in = None
    while True:
        new = reader.poll()
        polls += 1
        if a.or_idle and polls > 1:
            idle = False
            for c, _, d in new:
                if c == 'HEALTH':
                    h = lcm_messages.health(d)
                    if h['source'] == a.or_idle:
                        idle = idle or h['msgs_in'] == idle_in
                        idle_in = h['msgs_in']
            if idle:
                short = '?' if end is None or newest is None else f'{(end - newest) / 1e6:.1f}'
                print(f'log_wait: {a.or_idle} idle (msgs_in {idle_in}) with {reached} {a.reach}, '
                      f'the newest {short} s short')
                break
        count += len(new)
        if a.events is not None:
            what = f'{count} of {a.events} events'
            if count >= a.events:
                break
        elif last is not None:
            what = f'{count} events, not the last {last[0]} of {a.last_of}'
            if any(c == last[0] and d == last[1] for c, _, d in new):
                break
        else:
            if end is None:
                site = next((e for e in new if e[0] == 'SITE'), None)
                if site is not None:
                    end = utime(site[2]) + round((a.end_after_site - a.slack) * 1e6)
            for c, _, d in new:
                if c == a.reach:
                    reached += 1
                    t = utime(d)
                    if t is not None and (newest is None or t > newest):
                        newest = t
            if end is None:
                what = 'no SITE yet'
            elif newest is None:
                what = f'no {a.reach} yet'
            else:
                what = f'{reached} {a.reach}, the newest {(end - newest) / 1e6:.1f} s short'
                if newest >= end:
                    break
        if time.time() > deadline:
            sys.exit(f'FAIL: {" ".join(a.log)}: waited {a.timeout:g} s: {what}')
        if a.pid is not None and not alive(a.pid):
            sys.exit(f'FAIL: {" ".join(a.log)}: process {a.pid} exited while waiting: {what}')
        time.sleep(0.05)
    print(f'log_wait: {" ".join(os.path.basename(x) for x in a.log)}: ready after '
          f'{time.time() - t0:.1f} s')


if __name__ == '__main__':
    main()
