#!/usr/bin/env python3
"""Checks what mosquitto_sub -v wrote (one "TOPIC PAYLOAD" line per message) for mqtt_live_netns.sh,
polling every 50 ms with an upper bound rather than sleeping a fixed time.

  mqtt_check.py wait FILE TOPIC [--count N] [--field K=V ...] [--contains K=TEXT] [--timeout S]
      N messages (default 1) on TOPIC whose JSON has field K equal to V (compared as JSON: 5,
      "x", true) and field K holding TEXT.
  mqtt_check.py static FILE
      the messages mqtt_bus_publish sent in part (b), field by field (docs/mqtt.md).
  mqtt_check.py rate FILE --topic T --pid P --count N --max-hz H --seconds S
      N poses were published in S seconds on one tag; the bridge of pid P (--max-pose-hz H)
      sent at most S * H + 2 of them, the last one among them, and its HEALTH note counts the
      others as merged (sent + merged = N).
  mqtt_check.py outage FILE --topic T --first F --count N
      prints "received R of N, missing M: FIRST..LAST" (each pose's number is its num_used) and
      writes the missing numbers as a JSON list on stdout's last line.
Exit 0 when the condition holds, 1 with "FAIL: ..." otherwise.
"""
import argparse
import json
import math
import re
import sys
import time


def messages(path):
    out = []
    with open(path, encoding='utf-8', errors='replace') as f:
        for line in f:
            topic, _, payload = line.rstrip('\n').partition(' ')
            try:
                out.append((topic, json.loads(payload)))
            except ValueError:
                out.append((topic, None))
    return out


def on(path, topic):
    return [m for t, m in messages(path) if t == topic and m is not None]


def fail(what):
    sys.exit(f'FAIL: {what}')


def near(a, b, tol=1e-9):
    return a is not None and abs(a - b) <= tol


def wait(a):
    fields = [(k, json.loads(v)) for k, _, v in (f.partition('=') for f in a.field)]
    contains = [(k, v) for k, _, v in (c.partition('=') for c in a.contains)]
    deadline = time.time() + a.timeout
    while True:
        hits = [m for m in on(a.file, a.topic)
                if all(m.get(k) == v for k, v in fields)
                and all(v in str(m.get(k, '')) for k, v in contains)]
        if len(hits) >= a.count:
            return
        if time.time() > deadline:
            fail(f'{a.file}: {len(hits)} of {a.count} messages on {a.topic} with {a.field} '
                 f'{a.contains} within {a.timeout:.0f} s; last on it: '
                 f'{(on(a.file, a.topic) or [None])[-1]}')
        time.sleep(0.05)


def static(a):
    f = a.file
    # Poses 0..4 of T1 on POSE_FUSED (mqtt_bus_publish pose POSE_FUSED T1 0 5 0).
    poses = on(f, 'ips/lab/tag/T1/pose')
    got = sorted(p['num_used'] for p in poses)
    if got != [0, 1, 2, 3, 4]:
        fail(f'ips/lab/tag/T1/pose: poses {got}, expected 0..4')
    for p in poses:
        n = p['num_used']
        assert p['channel'] == 'POSE_FUSED' and p['source'] == 'test' and p['tag'] == 'T1', p
        assert near(p['x'], n * 0.01) and p['y'] == 2.5 and p['z'] == 1.2, p
        assert p['cov'] == [0.04, 0.01, 0, 0.01, 0.01, 0, 0, 0, 0.09], p
        # [[0.04, 0.01], [0.01, 0.01]]: eigenvalues 0.025 +- sqrt(0.015^2 + 0.01^2).
        r = math.hypot(0.015, 0.01)
        e = p['ellipse_2sigma']
        assert near(e['semi_major_m'], 2 * math.sqrt(0.025 + r), 1e-12), e
        assert near(e['semi_minor_m'], 2 * math.sqrt(0.025 - r), 1e-12), e
        assert near(e['angle_deg'], math.degrees(0.5 * math.atan2(0.02, 0.03)), 1e-9), e
        assert near(p['z_2sigma_m'], 0.6, 1e-12), p
        assert p['velocity'] == [0.5, 0, None] and near(p['heading_deg'], 90), p
        assert p['residual_m'] == 0.05 and p['status'] == 9 and p['flags'] == ['ok', '2d'], p
        assert isinstance(p['utime'], int) and p['time'].endswith('Z'), p
    print(f'ok: 5 poses of T1, every field; ellipse {poses[0]["ellipse_2sigma"]}')
    # A tag id with '/' on POSE_UWB: its topic level sanitised, the payload as published.
    uwb = on(f, 'ips/lab/tag/T_2/pose')
    if sorted(p['num_used'] for p in uwb) != [10, 11] or any(
            p['tag'] != 'T/2' or p['channel'] != 'POSE_UWB' for p in uwb):
        fail(f'ips/lab/tag/T_2/pose: {uwb}')
    print('ok: tag "T/2" on POSE_UWB -> ips/lab/tag/T_2/pose, "tag": "T/2"')
    zones = sorted(on(f, 'ips/lab/tag/T1/zone'), key=lambda z: z['seq'])
    want = [dict(utime=1764700000000001, time='2025-12-02T18:26:40.000001Z', source='ips-zones',
                 seq=1, tag='T1', zone_id='Z1', zone_name='Zone Z1', floor=1, event='enter',
                 dwell_s=12.5, x=3, y=4, z=1.2, pose_channel='POSE_FUSED', alert=True),
            dict(utime=1764700000000002, time='2025-12-02T18:26:40.000002Z', source='ips-zones',
                 seq=2, tag='T1', zone_id='any', zone_name='Zone any', floor=None, event='leave',
                 dwell_s=12.5, x=3, y=4, z=1.2, pose_channel='POSE_FUSED', alert=False)]
    if zones != want:
        fail(f'ips/lab/tag/T1/zone: {zones}, expected {want}')
    print('ok: 2 zone events (enter on floor 1, leave of a zone on every floor: floor null)')
    alerts = sorted(on(f, 'ips/lab/alert'), key=lambda x: x['seq'])
    want = [dict(utime=1764700000000000 + s, time=f'2025-12-02T18:26:40.00000{s}Z',
                 source='ips-zones', seq=s, id=7, kind='zone', severity='critical', state=st,
                 subject='T1/Z1', text='T1 entered Z1 (restricted)')
            for s, st in ((1, 'raised'), (2, 'cleared'))]
    if alerts != want:
        fail(f'ips/lab/alert: {alerts}, expected {want}')
    print('ok: alert 7 raised and cleared')
    h = on(f, 'ips/lab/health/fake_1')
    if len(h) != 1:
        fail(f'ips/lab/health/fake_1: {h}')
    h = h[0]
    assert h['source'] == 'fake+1' and h['state'] == 'degraded' and h['host'] == 'test-host', h
    assert h['pid'] == 4242 and h['msgs_in'] == 42 and h['last_error'] == 'disk full', h
    assert h['uptime_s'] == 3.5 and h['note'] == 'a note' and h['version'] == '0.1.0 (test)', h
    print('ok: HEALTH of process "fake+1" -> ips/lab/health/fake_1, state "degraded"')


def rate(a):
    deadline = time.time() + 30
    while True:
        poses = on(a.file, a.topic)
        nums = [p['num_used'] for p in poses]
        notes = [m['note'] for m in on(a.file, a.health_topic) if m.get('pid') == a.pid]
        merged = [int(x) for x in re.findall(r': (\d+) merged', notes[-1])] if notes else []
        if nums and nums[-1] == a.last and merged and len(nums) + merged[0] == a.count:
            break
        if time.time() > deadline:
            fail(f'{a.topic}: {nums}; the bridge (pid {a.pid}) says {notes[-1:]}')
        time.sleep(0.05)
    limit = a.seconds * a.max_hz + 2
    print(f'{a.count} poses in {a.seconds} s -> {len(nums)} sent at --max-pose-hz {a.max_hz} '
          f'({nums}), {merged[0]} merged')
    if len(nums) > limit or len(nums) < a.seconds * a.max_hz - 1:
        fail(f'{len(nums)} poses sent, expected about {a.seconds * a.max_hz} (at most {limit})')
    if nums != sorted(nums):
        fail(f'poses out of order: {nums}')


def outage(a):
    got = {p['num_used'] for p in on(a.file, a.topic)}
    want = set(range(a.first, a.first + a.count))
    missing = sorted(want - got)
    extra = sorted(got - want)
    if extra:
        fail(f'{a.topic}: poses never published: {extra[:10]}')
    span = f'{missing[0]}..{missing[-1]}' if missing else '-'
    print(f'received {len(got)} of {a.count}, missing {len(missing)}: {span}')
    print(json.dumps(missing))


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    sub = p.add_subparsers(dest='what', required=True)
    w = sub.add_parser('wait')
    w.add_argument('file')
    w.add_argument('topic')
    w.add_argument('--count', type=int, default=1)
    w.add_argument('--field', action='append', default=[])
    w.add_argument('--contains', action='append', default=[])
    w.add_argument('--timeout', type=float, default=60)
    s = sub.add_parser('static')
    s.add_argument('file')
    r = sub.add_parser('rate')
    r.add_argument('file')
    r.add_argument('--topic', required=True)
    r.add_argument('--health-topic', required=True)
    r.add_argument('--pid', type=int, required=True)
    r.add_argument('--count', type=int, required=True)
    r.add_argument('--last', type=int, required=True)
    r.add_argument('--max-hz', type=float, required=True)
    r.add_argument('--seconds', type=float, required=True)
    o = sub.add_parser('outage')
    o.add_argument('file')
    o.add_argument('--topic', required=True)
    o.add_argument('--first', type=int, required=True)
    o.add_argument('--count', type=int, required=True)
    a = p.parse_args()
    try:
        dict(wait=wait, static=static, rate=rate, outage=outage)[a.what](a)
    except AssertionError as e:
        fail(f'payload: {e}')


if __name__ == '__main__':
    main()
