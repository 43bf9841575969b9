#!/usr/bin/env python3
"""Three fake u-blox XPLR-AOA anchors on pseudo-terminals for the ips-ble-aoa integration test.

Each anchor is a pty's master side; ips-ble-aoa opens the slave through a symbolic link we
control (LINK -> /dev/pts/N), the way udev gives a real anchor a stable name. "Unplugging" closes
the master and removes the link (a hang-up, then the node is gone), as when a C211 is pulled out.

Every anchor answers the AT interface as the u-blox XPLR-AOA user guide (appendix A) describes:
echo on until ATE0 (the command echoed as typed, then the answer), "+UMLA:<mac>p" before OK for
AT+UMLA=1, OK for everything else, except one command per anchor that may be answered ERROR.
Nothing is streamed before AT+UDFENABLE=1 has been answered (except by C, which refuses a
command and streams anyway, as an anchor set to calculate angles at start-up does).

  fake_xplr_aoa.py LINK_A LINK_B LINK_C DRIVER_LOG WORK

writes WORK/sent.json (every event line, with the wall time before its write, and the unplug and
replug times of A), WORK/received.json (the bytes each anchor received, per plug-in), and
WORK/done; then waits for WORK/stop. It waits for the HEALTH reports the test checks in
WORK/aoa.lcm (the lcm-logger's recording), at most 60 s each.
"""
import json
import os
import select
import sys
import threading
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'integration'))
import fake_device_lib  # noqa: E402
from fake_device_lib import opened_count  # noqa: E402
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
import health_wait  # noqa: E402

COMMAND_OK = b'\r\nOK\r\n'


class Anchor:
    def __init__(self, name, link, mac, refuse=None):
        self.name, self.link, self.mac, self.refuse = name, link, mac, refuse
        self.lock = threading.Lock()
        self.master = None
        self.sessions = []   # bytes received, one entry per plug-in
        self.pending = b''
        self.echo = True
        self.enabled = threading.Event()
        self.refused = threading.Event()

    def plug(self):
        with self.lock:
            self.master, slave = os.openpty()
            tty.setraw(self.master)
            self.slave = slave
            os.symlink(os.ttyname(slave), self.link)
            self.sessions.append(b'')
            self.pending = b''
            self.echo = True
            self.enabled.clear()

    def unplug(self):
        with self.lock:
            os.close(self.master)
            os.close(self.slave)
            os.unlink(self.link)
            self.master = None

    def send(self, data):
        with self.lock:
            if self.master is not None:
                os.write(self.master, data.encode('latin-1') if isinstance(data, str) else data)

    def serve(self):
        """Reads what is waiting and answers complete commands (called by the service thread)."""
        with self.lock:
            if self.master is None:
                return
            try:
                chunk = os.read(self.master, 256)
            except OSError:
                return
            self.sessions[-1] += chunk
            self.pending += chunk
            while b'\r' in self.pending:
                command, self.pending = self.pending.split(b'\r', 1)
                reply = command + b'\r' if self.echo else b''
                text = command.decode('latin-1')
                if text == 'ATE0':
                    self.echo = False
                if text == self.refuse:
                    reply += b'\r\nERROR\r\n'
                    self.refused.set()
                elif text == 'AT+UMLA=1':
                    reply += b'\r\n+UMLA:' + self.mac.encode() + b'p' + COMMAND_OK
                else:
                    reply += COMMAND_OK
                os.write(self.master, reply)
                if text == 'AT+UDFENABLE=1':
                    self.enabled.set()


def service(anchors, stop):
    while not stop.is_set():
        fds = {}
        for a in anchors:
            with a.lock:
                if a.master is not None:
                    fds[a.master] = a
        try:
            ready, _, _ = select.select(list(fds), [], [], 0.02)
        except (OSError, ValueError):
            continue
        for fd in ready:
            fds[fd].serve()


def wait_for(predicate, timeout_s, what):
    fake_device_lib.wait_for(predicate, timeout_s, what, 'fake anchors')


def wait_health(work, what, **conditions):
    missing = health_wait.wait(os.path.join(work, 'aoa.lcm'), source='ips-ble-aoa', **conditions)
    if missing:
        sys.exit(f'fake anchors: timed out waiting for {what}: {missing}')


def main(link_a, link_b, link_c, log, work):
    a = Anchor('A', link_a, '6C1DEBA09862')
    b = Anchor('B', link_b, '6C1DEBA0AAAA')
    c = Anchor('C', link_c, '6C1DEBA0CCCC', refuse='AT+UDFCFG=1,50')
    anchors = [a, b, c]
    sent = []

    def event(anchor, text, end='\r\n'):
        sent.append({'anchor': anchor.name, 't_us': int(time.time() * 1e6), 'text': text})
        anchor.send(text + end)

    for x in anchors:
        x.plug()
    stop = threading.Event()
    server = threading.Thread(target=service, args=(anchors, stop), daemon=True)
    server.start()
    wait_for(lambda: all(opened_count(log, x.link) == 1 for x in anchors), 60,
             'the driver to open the three anchors')
    # Garbled first lines: what a port still held (the tail of an event, line noise).
    a.send(b'\x00\xfe\x13 5F60C,-68,-30,42\r\n+UUDF:6C1DEBA5F60C,-68,-30,4\r\n')
    wait_for(lambda: a.enabled.is_set() and b.enabled.is_set() and c.refused.is_set(), 60,
             'the AT conversations')
    # One HEALTH naming C's refused command before anything else goes wrong.
    wait_health(work, "a HEALTH naming C's refused command",
                error='the anchor answered ERROR to AT+UDFCFG=1,50')

    event(a, '+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,"6C1DEBA09862","",1606101,25')
    event(a, '+UUDF:6C1DEBA5F60C,-67,-28,40,0,38,"6C1DEBA09862","",1606201,26')
    event(a, '+UUDF:6C1DEBA5F60C,-67,-28,40,0,38,"6C1DEBA09862","",1606201,26')  # duplicate
    event(a, '+UUDF:6C1DEBA5F60C,-69,-25,41,0,39,"6C1DEB', end='')            # one line in
    time.sleep(0.05)                                                           # two writes
    event(a, 'A09862","",1606301,27')
    # B: older firmware, nine fields, 0..180 deg (the driver runs with --angle-range auto).
    event(b, '+UUDF:6C1DEBA5F60D,-71,45,80,-72,37,"6C1DEBA0AAAA","",5000')   # range unknown yet
    event(b, '+UUDF:6C1DEBA5F60D,-72,120,95,-73,38,"6C1DEBA0AAAA","",5100')
    event(b, '+UUDF:6C1DEBA5F60D,-72,120,95,-73,38,"6C1DEBA0AAAA","",5100')  # duplicate
    event(b, '+UUDF:6C1DEBA5F60D,-73,100,90,-74,39,"6C1DEBA0AAAA","",5200')
    event(c, '+UUDF:6C1DEBA5F60C,-60,5,-3,0,37,"6C1DEBA0CCCC","lat,50.1",777,7')
    event(c, '+UUDF:6C1DEBA5F60C,-61,6,-2,0,38,"6C1DEBA0CCCC","\x1b[2J",877,8')
    event(a, '+UUDF:6C1DEBA5F60C,-70,-20,40,0,37,"6C1DEBA09862","",16064', end='')  # cut by
    time.sleep(0.3)                                                                 # the unplug
    sent.append({'anchor': 'A', 't_us': int(time.time() * 1e6), 'text': 'unplug'})
    a.unplug()
    t_unplug = sent[-1]['t_us']
    for k in range(5):  # B keeps publishing while A is gone
        time.sleep(0.3)
        event(b, f'+UUDF:6C1DEBA5F60D,-70,{91 + k},80,-71,37,"6C1DEBA0AAAA","",{6000 + 100 * k}')
    # A HEALTH while A is gone, and B's five events published before the replug.
    wait_health(work, "a HEALTH while A is gone and B's events", state=1, error='gone; retrying',
                after=t_unplug, channel='BLE_AOA', count=5)
    a.plug()
    sent.append({'anchor': 'A', 't_us': int(time.time() * 1e6), 'text': 'replug'})
    wait_for(lambda: opened_count(log, a.link) == 2, 60, 'the driver to reopen A')
    wait_for(a.enabled.is_set, 60, "A's second AT conversation")
    time.sleep(0.1)
    # Replugging the USB cable powered the board again: uptime and counter start over.
    event(a, '+UUDF:6C1DEBA5F60C,-66,-10,30,0,37,"6C1DEBA09862","",1200,0')
    event(a, '+UUDF:6C1DEBA5F60C,-65,-5,31,0,38,"6C1DEBA09862","",1300,1')  # the test waits
    with open(os.path.join(work, 'sent.json'), 'w') as f:
        json.dump(sent, f)
    with open(os.path.join(work, 'received.json'), 'w') as f:
        json.dump({x.name: [s.decode('latin-1') for s in x.sessions] for x in anchors}, f)
    open(os.path.join(work, 'done'), 'w').close()
    wait_for(lambda: os.path.exists(os.path.join(work, 'stop')), 60, 'the end of the test')
    stop.set()
    for x in anchors:
        x.unplug()


if __name__ == '__main__':
    if len(sys.argv) != 6:
        sys.exit('usage: fake_xplr_aoa.py LINK_A LINK_B LINK_C DRIVER_LOG WORK')
    main(*sys.argv[1:])
