#!/usr/bin/env python3
"""scripts/bench-bus-load's helper.

  bus_load.py watch OUT.json NAME=PID...   samples the processes' CPU time (/proc/PID/stat) and
      resident memory (VmRSS, VmHWM of /proc/PID/status) every 0.2 s until SIGTERM or SIGINT, then
      writes per process the CPU used meanwhile (% of one core) and the memory last seen.
  bus_load.py report DIR SHARDS RT RECV_BUF           the table and the goals from DIR's files (load.json of
      ips-fuse-latency --json, watch.json, rec.lcm and rec.json of ips-record, pids.txt).
Reads LCM logs and messages with tests/integration's independent decoders."""
import json
import os
import signal
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, 'tests', 'integration'))
import lcm_log  # noqa: E402
import lcm_messages  # noqa: E402

TICK = os.sysconf('SC_CLK_TCK')


def cpu_s(pid):
    with open(f'/proc/{pid}/stat') as f:
        rest = f.read().rsplit(')', 1)[1].split()
    return (int(rest[11]) + int(rest[12])) / TICK  # utime, stime: fields 14 and 15


def memory_mb(pid):
    out = {}
    with open(f'/proc/{pid}/status') as f:
        for line in f:
            key, _, value = line.partition(':')
            if key in ('VmRSS', 'VmHWM'):
                out[key] = int(value.split()[0]) / 1024
    return out.get('VmRSS'), out.get('VmHWM')


def watch(out_path, named_pids):
    procs = {}
    for item in named_pids:
        name, pid = item.rsplit('=', 1)
        procs[name] = {'pid': int(pid), 'cpu0': cpu_s(int(pid)), 't0': time.monotonic()}
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))

    def sample():
        for p in procs.values():
            try:
                p['cpu1'], p['t1'] = cpu_s(p['pid']), time.monotonic()
                p['rss_mb'], p['peak_mb'] = memory_mb(p['pid'])
            except (OSError, IndexError, ValueError):
                pass  # gone: its last sample stands
    while not stop:
        sample()
        time.sleep(0.2)
    sample()
    result = {}
    for name, p in procs.items():
        wall = p.get('t1', p['t0']) - p['t0']
        result[name] = {'pid': p['pid'], 'rss_mb': p.get('rss_mb'), 'peak_mb': p.get('peak_mb'),
                        'cpu_pct': 100 * (p.get('cpu1', p['cpu0']) - p['cpu0']) / wall
                        if wall > 0 else None, 'wall_s': wall}
    with open(out_path, 'w') as f:
        json.dump(result, f, indent=1)


def fnv_shard(tag, shards):
    h = 14695981039346656037
    for b in tag.encode():
        h = ((h ^ b) * 1099511628211) % 2**64
    return h % shards + 1


def fmt(v, spec='.0f'):
    return '-' if v is None else format(v, spec)


def report(work, shards, rt, recv_buf):
    load = json.load(open(os.path.join(work, 'load.json')))
    watched = json.load(open(os.path.join(work, 'watch.json')))
    side = json.load(open(os.path.join(work, 'rec.json')))
    fuse_pids = {}  # pid -> name
    with open(os.path.join(work, 'pids.txt')) as f:
        for line in f:
            name, pid = line.split()
            if name.startswith('ips-fuse'):
                fuse_pids[int(pid)] = name
    events, used, size = lcm_log.events(os.path.join(work, 'rec.lcm'))
    counts, poses, last_health = {}, {}, {}
    for chan, _, data in events:
        counts[chan] = counts.get(chan, 0) + 1
        if chan == 'POSE_FUSED':
            p = lcm_messages.pose(data)
            poses.setdefault(p['tag_id'], []).append(p['utime'])
        elif chan == 'HEALTH':
            h = lcm_messages.health(data)
            if h['pid'] in fuse_pids and h['source'] == 'ips-fuse':
                last_health[h['pid']] = h
    tags, loss = load['tags'], side['loss']
    published = dict(load['published'])
    published['POSE_FUSED'] = sum(h['msgs_out'] for h in last_health.values())
    goals = []  # (what, measured, goal, met)

    print(f'\n== the bus at scale: {tags} tags x {load["anchors"]} anchors x 10 Hz + IMU 100 Hz, '
          f'{"one ips-fuse" if shards == 1 else f"{shards} shards"}, {load["seconds"]:g} s '
          f'measured{f", SCHED_FIFO {rt}" if rt else ""}'
          f'{f", receive buffers {recv_buf} bytes" if recv_buf != 4194304 else ""} ==')
    print(f'load {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f} '
          f'(1, 5, 15 min; {os.cpu_count()} cores)')
    total = published['UWB_RANGE'] + published['IMU']
    print(f'published by ips-fuse-latency (whole run): {total} messages, '
          f'{total / (load["self"]["run_s"]):.0f}/s')
    # The load's own schedule (2 s of warm-up): short of it, the tool fell behind, and its
    # latencies are its own backlog, not the bus's or ips-fuse's.
    due = tags * (load['anchors'] * 10 + 100) * (load['seconds'] + 2)
    behind = total < 0.99 * due or (load['baseline_us']['p50'] or 0) > 1000
    if behind:
        print(f'WARNING: the load fell behind ({total} of {due} messages due; the bus loop p50 '
              f'{fmt(load["baseline_us"]["p50"])} us): the machine did not give it the CPU, and '
              f'the latencies below measure its backlog. Run again on a quieter machine.')
    print('\nper channel      published   recorded   missing')
    missing_rec = 0
    for chan in ('UWB_RANGE', 'IMU', 'POSE_FUSED'):
        rec = counts.get(chan, 0)
        missing_rec += max(0, published[chan] - rec)
        print(f'{chan:<14} {published[chan]:>11} {rec:>10} {published[chan] - rec:>9}')
    if used != size:
        print(f'note: rec.lcm unreadable from byte {used} of {size}')
    print(f'ips-record: kernel_drops {loss["kernel_drops"]}, queue_drops {loss["queue_drops"]}, '
          f'seq_lost {loss["seq_lost"]} of {loss["seq_received"]} numbered, dropped (its own queue) '
          f'{side["dropped"]}, recv_buf_bytes {loss["recv_buf_bytes"]}')
    bus_lost = loss['kernel_drops'] + loss['queue_drops'] + side['dropped'] + missing_rec
    print('\nips-fuse (final HEALTH)   in      expected  kernel queue seq_lost  out (poses) '
          'drops  recv_buf')
    for pid, name in sorted(fuse_pids.items(), key=lambda kv: kv[1]):
        h = last_health.get(pid)
        if h is None:
            print(f'{name}: no HEALTH recorded')
            bus_lost += 1
            continue
        print(f'{name:<22} {h["msgs_in"]:>9} {total:>9} {h["kernel_drops"]:>6} '
              f'{h["queue_drops"]:>5} {h["seq_lost"]:>8} {h["msgs_out"]:>12} {h["drops"]:>6} '
              f'{h["recv_buf_bytes"]:>9}')
        if h['last_error']:
            print(f'    last_error: {h["last_error"][:150]}')
        if h['note']:
            print(f'    note: {h["note"][:150]}')
        bus_lost += h['kernel_drops'] + h['queue_drops'] + h['seq_lost'] + max(
            0, total - h['msgs_in'])
    print(f'ips-fuse-latency: poses received {load["poses_received"]} of '
          f'{published["POSE_FUSED"]} published')
    bus_lost += max(0, published['POSE_FUSED'] - load['poses_received'])

    if shards > 1:
        dup = sum(len(u) - len(set(u)) for u in poses.values())
        by_shard = {k: 0 for k in range(1, shards + 1)}
        for tag, u in poses.items():
            by_shard[fnv_shard(tag, shards)] += len(u)
        out_by_shard = {}
        for pid, name in fuse_pids.items():
            k = int(name.split('-')[-1])
            out_by_shard[k] = last_health[pid]['msgs_out'] if pid in last_health else None
        one = dup == 0 and all(out_by_shard[k] == by_shard[k] for k in by_shard)
        print(f'\nshards: poses recorded per shard (tags by hash) {by_shard}, published per '
              f'shard (HEALTH msgs_out) {out_by_shard}, duplicate (tag, time) poses {dup}: '
              f'every tag from exactly one shard: {"yes" if one else "NO"}')
        goals.append(('every tag from one shard', 'yes' if one else 'no', 'yes', one))

    # As the tool's loop sees them, and by the kernel's receive stamps of its socket
    # (ips-fuse-latency reads the bus itself): the stamps leave the tool's own wake-ups out, so the
    # added latency by them is ips-fuse's whole share (its wake-up, its work, its publish), and the
    # tool's own wake-up beside it is what any subscriber's hop costs on this machine.
    print(f'\nlatency (us)                                 n      p50    p90    p99    max')
    rows = (('range -> pose', 'latency_us'), ('bus loop (own range back)', 'baseline_us'),
            ('added by ips-fuse', 'added_us'), ('by the kernel\'s stamps:', None),
            ('  a range\'s delivery (publish -> stamp)', 'delivery_us'),
            ('  a subscriber\'s wake-up (stamp -> read)', 'wake_us'),
            ('  added by ips-fuse (range -> pose stamp)', 'added_stamp_us'))
    for what, key in rows:
        v = load.get(key) if key else None
        if key is None or v is None:
            print(what)
            continue
        print(f'{what:<42} {v["n"]:>7} {fmt(v["p50"]):>6} {fmt(v["p90"]):>6} {fmt(v["p99"]):>6} '
              f'{fmt(v["max"]):>6}')
    for s in load.get('added_us_by_shard', []):
        print(f'  added, shard {s["shard"]}: {s["n"]} poses, p50 {fmt(s["p50"])}, p99 '
              f'{fmt(s["p99"])}')
    print(f'poses missing (a range without its pose within the run): {load["poses_missing"]} of '
          f'{load["measured_ranges"]} ({100 * load["poses_missing"] / max(1, load["measured_ranges"]):.1f} %)')

    print('\nprocess                cpu % of one core   rss MB   peak MB')
    procs = dict(watched)
    procs['ips-fuse-latency'] = {'cpu_pct': load['self']['cpu_pct'], 'rss_mb': None,
                                 'peak_mb': load['self']['peak_mb']}
    worst = 0.0
    for name, p in procs.items():
        worst = max(worst, p['peak_mb'] or 0)
        print(f'{name:<22} {fmt(p["cpu_pct"], ".1f"):>17} {fmt(p["rss_mb"], ".1f"):>8} '
              f'{fmt(p["peak_mb"], ".1f"):>9}')

    limit = 100 if tags <= 10 else 300
    p99 = load['added_stamp_us']['p99']
    goals.append((f'ips-fuse p99 added (stamps) <= {limit} us at {tags} tags', fmt(p99) +
                  (' (load behind)' if behind else ''), f'{limit}', p99 is not None and p99 <= limit))
    goals.append(('every process peak RSS <= 30 MB', f'{worst:.1f} MB', '30 MB', worst <= 30))
    goals.append((f'messages lost on the bus ({"documented 4 MiB" if recv_buf == 4194304 else recv_buf} '
                  f'buffer)', str(bus_lost), '0', bus_lost == 0))
    print('\ngoal                                                 measured    goal    met')
    for what, got, goal, met in goals:
        print(f'{what:<52} {got:>9} {goal:>7}    {"met" if met else "NOT met"}')
    return 0


if __name__ == '__main__':
    if len(sys.argv) >= 3 and sys.argv[1] == 'watch':
        watch(sys.argv[2], sys.argv[3:])
    elif len(sys.argv) == 6 and sys.argv[1] == 'report':
        sys.exit(report(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])))
    else:
        print(__doc__)
        sys.exit(2)
