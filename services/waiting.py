"""The one way dogged waits for something to become true: poll a condition until a deadline."""
from __future__ import annotations

import time


def poll(condition, timeout: float, period: float = 0.05, stop=None):
    """condition()'s first truthy value within `timeout` seconds, or None; asked at least once, and
    not again once `stop` (a StopFlag, say) is set."""
    end = time.monotonic() + timeout
    while True:
        value = condition()
        if value or stop or time.monotonic() >= end:
            return value or None
        time.sleep(period)
