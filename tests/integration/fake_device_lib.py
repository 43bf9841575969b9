"""Helpers of the fake serial devices the driver tests run on pseudo-terminals
(tests/drivers/*/fake_*.py): waiting for a condition, and counting how often the driver under test
logged that it opened a device."""
import sys
import time


def wait_for(predicate, timeout_s, what, who='fake device'):
    """Polls predicate every 20 ms; exits the script with a message after timeout_s."""
    end = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > end:
            sys.exit(f'{who}: timed out waiting for {what}')
        time.sleep(0.02)


def opened_count(log, link):
    """How many times the driver's log says ' opened <link> '."""
    try:
        with open(log, encoding='utf-8', errors='replace') as f:
            return f.read().count(f' opened {link} ')
    except FileNotFoundError:
        return 0
