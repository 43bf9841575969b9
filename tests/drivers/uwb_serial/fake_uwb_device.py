#!/usr/bin/env python3
"""A fake UWB tag on a pseudo-terminal for the ips-uwb-serial integration test.

The device is the pty's master side; ips-uwb-serial opens the slave through a symbolic link we
control (LINK -> /dev/pts/N), the way udev gives a real tag a stable name. "Unplugging" closes the
master and removes the link, which is what the driver sees when a USB tag is pulled out (a
hang-up, then the node is gone).

  fake_uwb_device.py listen LINK DRIVER_LOG WORK
      the driver only listens: writes PANS and RANGE lines (good and garbled), unplugs, waits,
      plugs in a new pty at the same link, writes more; writes WORK/sent.json (what was sent,
      with the wall time before each write) and WORK/listen.done, then waits for WORK/stop.
      It waits for the HEALTH reports the test checks in WORK/listen.lcm (the lcm-logger's
      recording), at most 60 s each.
  fake_uwb_device.py shell LINK WORK
      a DWM1001 with its shell: silent until "\\r\\r" (then a banner and the prompt), streams
      lec lines after "lec\\r", stops on the second "lec\\r"; records every byte it received
      in WORK/received.bin. Writes WORK/streaming once its lines are out; ends after "quit\\r".
"""
import json
import os
import select
import sys
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
import health_wait  # noqa: E402


def wait_health(work, what, **conditions):
    missing = health_wait.wait(os.path.join(work, 'listen.lcm'), source='ips-uwb-serial',
                               **conditions)
    if missing:
        sys.exit(f'fake device: timed out waiting for {what}: {missing}')

GUIDE_LEC = ('DIST,4,AN0,1151,5.00,8.00,2.25,6.44,AN1,0CA8,0.00,8.00,2.25,6.50,AN2,111C,5.00,'
             '0.00,2.25,3.24,AN3,1150,0.00,0.00,2.25,3.19,POS,2.55,2.01,1.71,98')


class Pty:
    def __init__(self, link):
        self.master, self.slave = os.openpty()
        # The device side writes bytes as they are; the driver sets the slave's own modes.
        tty.setraw(self.master)
        self.link = link
        os.symlink(os.ttyname(self.slave), link)

    def send(self, data):
        os.write(self.master, data.encode('latin-1') if isinstance(data, str) else data)

    def unplug(self):
        os.close(self.master)
        os.close(self.slave)
        os.unlink(self.link)


def wait_for(predicate, timeout_s, what):
    end = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > end:
            sys.exit(f'fake device: timed out waiting for {what}')
        time.sleep(0.02)


def opened_count(log):
    try:
        with open(log, encoding='utf-8', errors='replace') as f:
            return f.read().count(' opened ')
    except FileNotFoundError:
        return 0


def listen(link, log, work):
    sent = []

    def send(dev, text):
        sent.append({'t_us': int(time.time() * 1e6), 'text': text})
        dev.send(text)

    # Missing at start: the driver is already running and retrying, and has said so in HEALTH.
    wait_health(work, 'a HEALTH saying the device is missing', state=1,
                error='not available (No such file or directory)')
    dev = Pty(link)
    wait_for(lambda: opened_count(log) == 1, 60, 'the driver to open the device')
    send(dev, 'dwm> lec\r\n')                                   # shell echo: ignored
    send(dev, GUIDE_LEC + '\r\n')                               # 4 ranges + position
    send(dev, 'DIST,2,AN0,2F2F,3.05,2.68,0.00,2.21,AN1,2c9d,-0.04,2.91,0.00,2.39\r\n')
    send(dev, 'RANGE T7 A3 4.25 -78.5\n')
    send(dev, 'RANGE T7 A')                                     # one line in two writes
    time.sleep(0.05)
    send(dev, '4 5.5\n')
    send(dev, 'DIST,3,AN0,1151,5.00,8.00,2.25,6.44,AN1,0CA8,0.00,8.00,2.25,6.50\r\n')  # garbled
    send(dev, 'RANGE T7 A3 nan\n')                              # garbled
    send(dev, 'x' * 5000 + '\n')                                # overlong
    send(dev, 'POS,1.00,2.00,0.50,0\r\n')                       # no fix: not published
    # Every line before read (msgs_in 8: the echo up to POS), then one cut by the unplug: lost.
    wait_health(work, 'a HEALTH counting the 8 lines', msgs_in=8, after=sent[0]['t_us'])
    send(dev, 'RANGE T7 A3 9.99')
    time.sleep(0.05)
    t_unplug = int(time.time() * 1e6)
    dev.unplug()
    wait_health(work, 'a HEALTH while gone', state=1, error='gone; retrying', after=t_unplug)
    dev = Pty(link)
    wait_for(lambda: opened_count(log) == 2, 60, 'the driver to reopen the device')
    send(dev, 'RANGE T7 A3 4.30 -79.0\n')
    send(dev, GUIDE_LEC + '\r\n')                               # the test waits for these
    with open(os.path.join(work, 'sent.json'), 'w') as f:
        json.dump(sent, f)
    open(os.path.join(work, 'listen.done'), 'w').close()
    wait_for(lambda: os.path.exists(os.path.join(work, 'stop')), 60, 'the end of the test')
    dev.unplug()


BANNER = ('\r\nDWM1001 TWR Real Time Location System\r\n\r\nCopyright :  2016-2019 LEAPS and '
          'Decawave\r\nLicense   :  Please visit https://decawave.com/dwm1001_license\r\n'
          'Compiled  :  Mar  4 2019 09:01:41\r\n\r\nHelp      :  ? or help\r\n\r\ndwm> ')
SHELL_LINES = [
    'DIST,2,AN0,1151,5.00,8.00,2.25,6.44,AN1,0CA8,0.00,8.00,2.25,6.50,POS,2.55,2.01,1.71,98',
    'DIST,2,AN0,1151,5.00,8.00,2.25,6.40,AN1,0CA8,0.00,8.00,2.25,6.52,POS,2.56,2.02,1.70,97',
    'DIST,2,AN0,1151,5.00,8.00,2.25,6.38,AN1,0CA8,0.00,8.00,2.25,6.55,POS,2.57,2.03,1.69,96',
]


def shell(link, work):
    dev = Pty(link)
    received = b''
    in_shell = False
    lec_on = False
    end = time.monotonic() + 60
    while time.monotonic() < end and not received.endswith(b'quit\r'):
        r, _, _ = select.select([dev.master], [], [], 0.05)
        if not r:
            continue
        chunk = os.read(dev.master, 256)
        received += chunk
        if not in_shell and received.endswith(b'\r\r'):
            in_shell = True
            dev.send(BANNER)
        elif in_shell and received.endswith(b'lec\r'):
            lec_on = not lec_on
            dev.send('lec\r\n')  # the shell echoes the command
            if lec_on:
                for line in SHELL_LINES:
                    dev.send(line + '\r\n')
                    time.sleep(0.1)
                open(os.path.join(work, 'streaming'), 'w').close()
            else:
                dev.send('dwm> ')
    with open(os.path.join(work, 'received.bin'), 'wb') as f:
        f.write(received)
    dev.unplug()


if __name__ == '__main__':
    if sys.argv[1] == 'listen':
        listen(sys.argv[2], sys.argv[3], sys.argv[4])
    elif sys.argv[1] == 'shell':
        shell(sys.argv[2], sys.argv[3])
    else:
        sys.exit('usage: fake_uwb_device.py listen LINK DRIVER_LOG WORK | shell LINK WORK')
