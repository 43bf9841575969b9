#!/usr/bin/env python3
"""Floods the LCM multicast group with small valid LCM messages as fast as Python can send them:
ble_aoa_t on BLE_AOA from anchor F, numbered seq FIRST..FIRST+COUNT-1 (so that a receiver's
sequence-gap counter sees exactly what it lost). The type's fingerprint is taken from a log that
holds a ble_aoa_t (ips-sim --scenario aoa-hall --out). Prints the number of datagrams sent.

  lcm_flood.py FINGERPRINT_LOG COUNT [FIRST] [--group 239.255.76.67:7667]
"""
import argparse
import socket
import struct
import sys

import lcm_log


def lcm_string(s):
    b = s.encode() + b'\0'
    return struct.pack('>i', len(b)) + b


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('fingerprint_log')
    ap.add_argument('count', type=int)
    ap.add_argument('first', type=int, nargs='?', default=0)
    ap.add_argument('--group', default='239.255.76.67:7667')
    a = ap.parse_args()
    evs, _, _ = lcm_log.events(a.fingerprint_log)
    fp = next((d[:8] for c, _, d in evs if c == 'BLE_AOA'), None)
    if fp is None:
        sys.exit(f'lcm_flood.py: no BLE_AOA in {a.fingerprint_log}')
    host, port = a.group.split(':')
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
    head = lcm_string('flood') + lcm_string('F') + lcm_string('T')
    sent = 0
    for i in range(a.count):
        seq = a.first + i
        msg = (fp + struct.pack('>q', 1767225600000000 + seq) + head +
               struct.pack('>fffhqi', 10.0, 5.0, -60.0, 37, seq, seq) + lcm_string(''))
        # LCM's short-message header: magic "LC02", a packet number, the channel, then the data.
        pkt = struct.pack('>II', 0x4C433032, i & 0xFFFFFFFF) + b'BLE_AOA\0' + msg
        while True:
            try:
                sock.sendto(pkt, (host, int(port)))
                sent += 1
                break
            except BlockingIOError:
                continue
            except OSError as e:  # ENOBUFS: the sender's own queue is full; try again
                if e.errno != 105:
                    raise
    print(sent)


if __name__ == '__main__':
    main()
