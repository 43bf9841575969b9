#!/usr/bin/env python3
"""Plays the anchors' server for the ips-uwb-tdoa-anchors integration tests.

  anchor_server.py tcp PORT RECORDS SPLIT PAUSE_S DONE
      Listens on 127.0.0.1:PORT, sends the first SPLIT lines of RECORDS to the first client in
      small pieces (records split across TCP segments and reads), closes the connection and the
      listening socket (the server goes away) for PAUSE_S seconds, then listens again and sends
      the rest to the next client. Touches DONE when everything is sent, then holds the
      connection open until the client closes it (at most 30 s).
  anchor_server.py udp PORT RECORDS EXTRA
      Sends the lines of RECORDS to 127.0.0.1:PORT as datagrams of one, two or three records
      (newline-separated, or back to back with no separator), 1 ms apart, then each line of the
      file EXTRA as a datagram of its own.
"""
import os
import socket
import sys
import time


def tcp(port, records, split, pause_s, done):
    data = open(records, 'rb').read().splitlines(keepends=True)
    parts = [b''.join(data[:split]), b''.join(data[split:])]
    conn = None
    for k, part in enumerate(parts):
        srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        srv.bind(('127.0.0.1', port))
        srv.listen(1)
        srv.settimeout(60)
        conn, _ = srv.accept()
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        # Pieces of 1 to 97 bytes, a pause every few, so that records straddle reads.
        i, n = 0, 0
        while i < len(part):
            step = 1 + (n * 37) % 97
            conn.sendall(part[i:i + step])
            i += step
            n += 1
            if n % 8 == 0:
                time.sleep(0.002)
        srv.close()
        if k == 0:
            conn.shutdown(socket.SHUT_WR)
            conn.close()
            time.sleep(pause_s)
    open(done, 'w').close()
    conn.settimeout(60)
    try:
        while conn.recv(4096):
            pass
    except OSError:
        pass


def udp(port, records, extra):
    lines = open(records, 'rb').read().splitlines()
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    i, n = 0, 0
    while i < len(lines):
        k = 1 + n % 3
        group = lines[i:i + k]
        sep = b'' if n % 5 == 4 else b'\n'
        sock.sendto(sep.join(group) + (b'\n' if n % 2 else b''), ('127.0.0.1', port))
        i += k
        n += 1
        time.sleep(0.001)
    for line in open(extra, 'rb').read().splitlines():
        sock.sendto(line, ('127.0.0.1', port))
        time.sleep(0.001)


if __name__ == '__main__':
    if sys.argv[1] == 'tcp':
        tcp(int(sys.argv[2]), sys.argv[3], int(sys.argv[4]), float(sys.argv[5]), sys.argv[6])
    elif sys.argv[1] == 'udp':
        udp(int(sys.argv[2]), sys.argv[3], sys.argv[4])
    else:
        sys.exit(__doc__)
