#!/usr/bin/env python3
"""A fake serial barometer on a pseudo-terminal for the ips-baro integration test: what the
Arduino sketch of docs/hardware/barometer.md prints ("P <Pa> T <degC> [H <%>]", CRLF), plus the
bad lines a real one can print (a failed read gives "nan", a wrong wiring 0, garbage at a
reset).

ips-baro opens the slave side through a symbolic link we control (LINK -> /dev/pts/N), the way
udev gives a USB serial adapter a stable name. "Unplugging" closes the master and removes the
link (a hang-up, then the node is gone), as when the USB cable is pulled.

  fake_baro_serial.py LINK DRIVER_LOG WORK

writes WORK/sent.json (every line with the wall time before its write, and the unplug and
replug times) and WORK/done, then waits for WORK/stop. It waits for the HEALTH reports the test
checks in WORK/baro.lcm (the lcm-logger's recording), at most 60 s each.
"""
import json
import os
import sys
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'integration'))
import fake_device_lib  # noqa: E402
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
import health_wait  # noqa: E402
from fake_device_lib import opened_count  # noqa: E402


class Device:
    def __init__(self, link):
        self.link, self.master, self.slave = link, None, None

    def plug(self):
        self.master, self.slave = os.openpty()
        tty.setraw(self.master)
        os.symlink(os.ttyname(self.slave), self.link)

    def unplug(self):
        os.close(self.master)
        os.close(self.slave)
        os.unlink(self.link)

    def write(self, data):
        os.write(self.master, data if isinstance(data, bytes) else data.encode('latin-1'))


def wait_for(predicate, timeout_s, what):
    fake_device_lib.wait_for(predicate, timeout_s, what, 'fake barometer')


def wait_health(work, what, **conditions):
    missing = health_wait.wait(os.path.join(work, 'baro.lcm'), source='ips-baro', **conditions)
    if missing:
        sys.exit(f'fake barometer: timed out waiting for {what}: {missing}')


def main(link, log, work):
    dev = Device(link)
    sent = []

    def line(text, end='\r\n', pause=0.05):
        sent.append({'t_us': int(time.time() * 1e6), 'text': text})
        dev.write(text + end)
        time.sleep(pause)

    def mark(what):
        sent.append({'t_us': int(time.time() * 1e6), 'text': what})

    dev.plug()
    wait_for(lambda: opened_count(log, link) == 1, 60, 'the driver to open the device')
    time.sleep(0.2)
    line('# ips-baro sketch: BMP280 at 0x76')
    line('P 101325.12 T 21.43 H 45.2')
    line('P  101324.50\tT 21.44  ')                    # no H; extra blanks
    line('P 0 T 21.40')                                # bad: reported
    line('P 101324.00 T nan')                          # bad: held back (same second)
    line('P 101323.75 T 21.45 H 120.0')                # bad: held back
    sent.append({'t_us': int(time.time() * 1e6), 'text': 'P 101323.25 T 21.46 H 44.9'})
    dev.write('P 101323.25 T 2')                       # one line in two writes
    time.sleep(0.05)
    dev.write('1.46 H 44.9\r\n')
    time.sleep(1.3)                                    # past the report limit's second
    line(b'garbage\x00\xff'.decode('latin-1'))         # bad: reported, with the 2 held back
    wait_health(work, 'a HEALTH with that reason', state=1, error="unknown field 'garbage",
                after=sent[-1]['t_us'])
    line('P 101322', end='', pause=0.2)                # cut by the unplug
    mark('unplug')
    dev.unplug()
    wait_health(work, 'a HEALTH while it is away', state=1, error='gone; retrying',
                after=sent[-1]['t_us'] + 300000)
    dev.plug()
    mark('replug')
    wait_for(lambda: opened_count(log, link) == 2, 60, 'the driver to reopen the device')
    time.sleep(0.1)
    line('P 101322.00 T 21.47', end='\n')              # LF only
    line('T -5.5 P 101321.5')                          # any order (the test waits for it)
    with open(os.path.join(work, 'sent.json'), 'w') as f:
        json.dump(sent, f)
    open(os.path.join(work, 'done'), 'w').close()
    wait_for(lambda: os.path.exists(os.path.join(work, 'stop')), 60, 'the end of the test')
    dev.unplug()


if __name__ == '__main__':
    if len(sys.argv) != 4:
        sys.exit('usage: fake_baro_serial.py LINK DRIVER_LOG WORK')
    main(*sys.argv[1:])
