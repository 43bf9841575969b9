#!/usr/bin/env python3
"""Waits for what site_live_netns.sh checks in an LCM log being written (lcm-logger), polling every
50 ms with an upper bound rather than sleeping a fixed time. Times are the logger's receive
timestamps (us, host clock), compared with `date +%s%6N` taken by the script.

  site_bus.py site LOG --after T --anchor ID --x X [--count N] [--timeout S]
      N SITE messages from ips-site received after T, every one of them (from the first after T
      on) with anchor ID at x = X: a SITE with anything else fails at once. Prints the delay from
      T to the first.
  site_bus.py poses LOG --after T --z Z [--count N] [--timeout S]
      N POSE_UWB received after T at height z = Z (the tag's height_m from the site the tracker
      holds: the lab's tag is tracked in 2D); once one is, a later one at another height fails.
Exit 0 when the condition holds, 1 with "FAIL: ..." otherwise.
"""
import argparse
import sys
import time

from log_wait import Reader
from lcm_messages import _Reader


def site(data):
    """site_t (lcmtypes/site_t.lcm): nested types are encoded without their fingerprint."""
    r = _Reader(data)
    m = dict(utime=r.take('q'), source=r.string(), name=r.string(), anchors={})
    for _ in range(r.take('i')):
        aid, kind = r.string(), r.string()
        pos = [r.take('d') for _ in range(3)]
        [r.take('d') for _ in range(3)]  # orientation
        r.take('b')  # enabled
        m['anchors'][aid] = dict(kind=kind, position=pos)
    for _ in range(r.take('i')):
        r.string()
        [r.take('d') for _ in range(3)]
    m['tags'] = {}
    for _ in range(r.take('i')):
        tid = r.string()
        m['tags'][tid] = r.take('d')
    m['site_yaml'] = r.string()
    return m


def pose_z(data):
    r = _Reader(data)
    r.take('q')
    r.string()
    r.string()
    return [r.take('d') for _ in range(3)][2]


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('what', choices=['site', 'poses'])
    p.add_argument('log')
    p.add_argument('--after', type=int, required=True)
    p.add_argument('--anchor')
    p.add_argument('--x', type=float)
    p.add_argument('--z', type=float)
    p.add_argument('--count', type=int, default=1)
    p.add_argument('--timeout', type=float, default=60)
    a = p.parse_args()
    reader = Reader([a.log])
    deadline = time.time() + a.timeout
    seen, first_ts, other = 0, None, 0
    while seen < a.count:
        for ch, ts, data in reader.poll():
            if ts <= a.after:
                continue
            if a.what == 'site' and ch == 'SITE':
                m = site(data)
                if m['source'] != 'ips-site':
                    sys.exit(f'FAIL: a SITE from {m["source"]!r} on the bus')
                x = m['anchors'].get(a.anchor, dict(position=[None]))['position'][0]
                if x != a.x:
                    sys.exit(f'FAIL: SITE {(ts - a.after) / 1e6:.2f} s after the mark has anchor '
                             f'{a.anchor} at x = {x}, not {a.x}')
            elif a.what == 'poses' and ch == 'POSE_UWB':
                z = pose_z(data)
                if abs(z - a.z) > 1e-9:
                    if seen:
                        sys.exit(f'FAIL: POSE_UWB at z = {z} after {seen} at z = {a.z}')
                    other += 1
                    continue
            else:
                continue
            seen += 1
            if first_ts is None:
                first_ts = ts
        if seen < a.count and time.time() > deadline:
            sys.exit(f'FAIL: {seen} of {a.count} {"SITE" if a.what == "site" else "POSE_UWB"} '
                     f'as wanted within {a.timeout:.0f} s'
                     + (f' ({other} POSE_UWB at another height)' if a.what == 'poses' else ''))
        time.sleep(0.05)
    what = (f'{a.count} SITE with {a.anchor} at x = {a.x}' if a.what == 'site'
            else f'{a.count} POSE_UWB at z = {a.z} ({other} before at another height)')
    print(f'{what}; the first {(first_ts - a.after) / 1e6:.2f} s after the mark')


if __name__ == '__main__':
    main()
