#!/usr/bin/env python3
"""Waits until an LCM log being written (lcm-logger) holds what a driver test is about to check,
instead of sleeping a fixed time that a loaded machine can overrun: a HEALTH report of a process,
and/or enough messages on a channel. Polls every 50 ms; exits 0 as soon as all the conditions
hold, 1 with "FAIL: ..." after --timeout seconds (default 60).

  health_wait.py LOG --source NAME [--state S] [--msgs-in M] [--error TEXT] [--after UTIME]
                     [--health N]
      N (default 1) HEALTH reports from NAME stamped after UTIME (us), in state S, with at least
      M msgs_in and TEXT in last_error when given
  health_wait.py LOG --channel CH [--after UTIME] [--count N] [--contains TEXT]
      N (default 1) messages on CH stamped after UTIME (the utime, first field of an ips type),
      counting only those whose bytes hold TEXT when given (e.g. a sensor's device path)
Both may be given; then both must hold. The fake devices import wait() to do the same.
"""
import argparse
import os
import struct
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'integration'))
from log_wait import Reader  # noqa: E402
import lcm_messages  # noqa: E402


def wait(log, source=None, state=None, msgs_in=None, error=None, after=0, health=1,
         channel=None, count=1, contains='', timeout=60.0):
    """Returns None once the conditions hold, else (after timeout s) what was missing."""
    deadline = time.time() + timeout
    reader = Reader([log])
    healths = msgs = 0
    while True:
        for c, _, d in reader.poll():
            if c == 'HEALTH' and source is not None:
                h = lcm_messages.health(d)
                if h['source'] == source and h['utime'] > after and \
                        (state is None or h['state'] == state) and \
                        (msgs_in is None or h['msgs_in'] >= msgs_in) and \
                        (error is None or error in h['last_error']):
                    healths += 1
            if channel is not None and c == channel and len(d) >= 16 and \
                    struct.unpack('>q', d[8:16])[0] > after and contains.encode() in d:
                msgs += 1
        if (source is None or healths >= health) and (channel is None or msgs >= count):
            return None
        if time.time() > deadline:
            want = []
            if source is not None:
                want.append(f'{healths} of {health} HEALTH from {source}'
                            + ('' if state is None else f' in state {state}')
                            + ('' if msgs_in is None else f' with msgs_in >= {msgs_in}')
                            + ('' if error is None else f' with last_error {error!r}'))
            if channel is not None:
                want.append(f'{msgs} of {count} {channel}')
            return f'{log}: after {timeout:.0f} s {", ".join(want)} stamped after {after}'
        time.sleep(0.05)


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('log')
    p.add_argument('--source')
    p.add_argument('--state', type=int)
    p.add_argument('--msgs-in', type=int)
    p.add_argument('--error')
    p.add_argument('--health', type=int, default=1)
    p.add_argument('--channel')
    p.add_argument('--count', type=int, default=1)
    p.add_argument('--contains', default='')
    p.add_argument('--after', type=int, default=0)
    p.add_argument('--timeout', type=float, default=60)
    a = p.parse_args()
    if a.source is None and a.channel is None:
        p.error('give --source NAME and/or --channel CH')
    missing = wait(a.log, a.source, a.state, a.msgs_in, a.error, a.after, a.health, a.channel,
                   a.count, a.contains, a.timeout)
    if missing:
        sys.exit(f'FAIL: {missing}')


if __name__ == '__main__':
    main()
