"""Checks ips-zones' ZONE_EVENT in a log against the crossings of the TRUTH path, computed here
independently of the C++ code: each TRUTH segment against each zone polygon (even-odd point in
polygon, segment-edge intersection, linear time along the segment).

  zone_events_check.py SITE.yaml LOG --exact        events on TRUTH: the crossings themselves
  zone_events_check.py SITE.yaml LOG --within 0.5   events on estimates: each truth ENTER/LEAVE
                                                    matched within 0.5 s, none extra

Prints the time errors; exits 1 with the reason when the check fails."""
import argparse
import sys

import yaml
from lcm_log import events
from lcm_messages import (ALERT_RAISED, ALERT_ZONE, ZONE_DWELL, ZONE_ENTER, ZONE_LEAVE, alert,
                          pose, zone_event)

NAMES = {ZONE_ENTER: 'ENTER', ZONE_LEAVE: 'LEAVE', ZONE_DWELL: 'DWELL'}


def contains(poly, x, y):
    inside = False
    j = len(poly) - 1
    for i in range(len(poly)):
        (xi, yi), (xj, yj) = poly[i], poly[j]
        if (yi > y) != (yj > y) and x < (xj - xi) * (y - yi) / (yj - yi) + xi:
            inside = not inside
        j = i
    return inside


def last_crossing(poly, p0, p1):
    """The largest fraction s of p0->p1 where it meets an edge of the polygon."""
    dx, dy = p1[0] - p0[0], p1[1] - p0[1]
    best = None
    j = len(poly) - 1
    for i in range(len(poly)):
        ax, ay = poly[j]
        ex, ey = poly[i][0] - ax, poly[i][1] - ay
        den = dx * ey - dy * ex
        j = i
        if abs(den) < 1e-15:
            continue
        wx, wy = ax - p0[0], ay - p0[1]
        s = (wx * ey - wy * ex) / den
        u = (wx * dy - wy * dx) / den
        if 0 <= s <= 1 and 0 <= u <= 1:
            best = s if best is None else max(best, s)
    return 1.0 if best is None else best


def truth_events(zones, truth):
    """(utime, tag, zone id, kind) of every boundary crossing of the TRUTH path, and the DWELLs."""
    out = []
    for tag in sorted({p['tag_id'] for p in truth}):
        track = [p for p in truth if p['tag_id'] == tag]
        for z in zones:
            poly = z['polygon']
            inside = contains(poly, *track[0]['position'][:2])
            enter = track[0]['utime'] if inside else None
            if inside:
                out.append((enter, tag, z['id'], ZONE_ENTER))
            for a, b in zip(track, track[1:]):
                now = contains(poly, *b['position'][:2])
                if now == inside:
                    continue
                s = last_crossing(poly, a['position'], b['position'])
                t = a['utime'] + s * (b['utime'] - a['utime'])
                if now:
                    enter = t
                elif z.get('dwell_s', 0) > 0 and t - enter >= z['dwell_s'] * 1e6:
                    out.append((enter + z['dwell_s'] * 1e6, tag, z['id'], ZONE_DWELL))
                out.append((t, tag, z['id'], ZONE_ENTER if now else ZONE_LEAVE))
                inside = now
    return sorted(out)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('site')
    ap.add_argument('log')
    mode = ap.add_mutually_exclusive_group(required=True)
    mode.add_argument('--exact', action='store_true')
    mode.add_argument('--within', type=float)
    args = ap.parse_args()

    site = yaml.safe_load(open(args.site))
    zones = site['zones']
    marks = {z['id']: z.get('alert', []) for z in zones}
    for z in zones:
        if isinstance(marks[z['id']], str):
            marks[z['id']] = [marks[z['id']]]
    ev, _, _ = events(args.log)
    truth = [pose(d) for ch, _, d in ev if ch == 'TRUTH']
    got = [zone_event(d) for ch, _, d in ev if ch == 'ZONE_EVENT']
    alerts = [alert(d) for ch, _, d in ev if ch == 'ALERT']
    if not truth:
        sys.exit('FAIL: no TRUTH in the log')
    if not got:
        sys.exit('FAIL: no ZONE_EVENT in the log')
    end = truth[-1]['utime']
    expected = truth_events(zones, truth)
    # A crossing in the last second may not be confirmed yet (0.3 m further at 1 m/s).
    expected = [e for e in expected if e[0] <= end - 1e6 or e[3] == ZONE_DWELL]
    hyst = {z['id']: z.get('hysteresis_m', 0.3) for z in zones}

    assert [e['seq'] for e in got] == list(range(len(got))), 'seq not 0, 1, 2, ...'
    used = [False] * len(got)
    errors = []
    tolerance = 1.0 if args.exact else args.within * 1e6  # us
    for t, tag, zid, kind in expected:
        if not args.exact and kind == ZONE_DWELL:
            continue
        best = None
        for i, e in enumerate(got):
            if used[i] or e['tag_id'] != tag or e['zone_id'] != zid or e['event'] != kind:
                continue
            if abs(e['utime'] - t) <= tolerance and (best is None or
                                                     abs(e['utime'] - t) < abs(got[best]['utime'] - t)):
                best = i
        if best is None:
            sys.exit(f'FAIL: no {NAMES[kind]} of {tag} in {zid} within {tolerance / 1e6} s of '
                     f'{(t - truth[0]["utime"]) / 1e6:.3f} s')
        used[best] = True
        errors.append((kind, (got[best]['utime'] - t) / 1e6))
    extra = [e for i, e in enumerate(got) if not used[i] and
             (args.exact or e['event'] != ZONE_DWELL) and e['utime'] <= end - 1e6]
    if extra:
        e = extra[0]
        sys.exit(f'FAIL: {len(extra)} events with no truth crossing, the first {NAMES[e["event"]]} '
                 f'of {e["tag_id"]} in {e["zone_id"]} at '
                 f'{(e["utime"] - truth[0]["utime"]) / 1e6:.3f} s')
    # The events the site marks are alerts, one each.
    marked = [e for e in got if NAMES[e['event']].lower() in marks[e['zone_id']]]
    assert all(e['alert'] for e in marked), 'a marked event without alert'
    assert sum(e['alert'] for e in got) == len(marked), 'alert on an unmarked event'
    zone_alerts = [a for a in alerts if a['kind'] == ALERT_ZONE]
    assert len(zone_alerts) == len(marked), f'{len(zone_alerts)} zone alerts, {len(marked)} marked'
    assert all(a['state'] == ALERT_RAISED for a in zone_alerts)
    assert [a['utime'] for a in zone_alerts] == [e['utime'] for e in marked]
    n = len(errors)
    worst = max(abs(x) for _, x in errors)
    mean = sum(x for _, x in errors) / n
    kinds = ', '.join(f'{sum(1 for k, _ in errors if k == kk)} {NAMES[kk]}'
                      for kk in (ZONE_ENTER, ZONE_LEAVE, ZONE_DWELL))
    print(f'{got[0]["pose_channel"]}: {n} truth events matched ({kinds}), time error mean '
          f'{mean:+.4f} s, worst {worst:.4f} s; {len(zone_alerts)} zone alerts; hysteresis '
          f'{sorted(set(hyst.values()))} m')


if __name__ == '__main__':
    main()
