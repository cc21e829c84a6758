"""Whether a live learner's fits (on their own thread, served live) have caught up with everything it was
taught: its status says no upkeep under way."""
from __future__ import annotations

import time

from bus_schema import Status, decoded
from services.demo.live import BusRecorder
from services.waiting import poll


def caught_up(statuses: list, since: float, taught: int | None = None) -> bool:
    """Whether the newest learner status in `statuses` ((key, bytes, arrival) as recorded) says no fit is under way,
    if it was composed after everything taught: with `taught` (the seq of the last pair taught), once the learner
    had taken that pair in and learned its backlog; without, if it arrived over half a second after `since`."""
    if not statuses or (taught is None and statuses[-1][2] < since + 0.5):
        return False
    status = decoded(Status, statuses[-1][0], statuses[-1][1])
    if status is None or status.counters.get("upkeep_under_way", 1) != 0:
        return False
    return taught is None or (status.counters.get("seq", -1) >= taught and status.counters.get("backlog", 1) == 0)


def wait_caught_up(bus: BusRecorder, learner: str = "learner", timeout: float = 120.0) -> float:
    """Wait until the fits of `learner` of the bus's instance have caught up (its statuses recorded
    meanwhile). Returns the seconds waited."""
    key = bus.keys.status("learner", learner)
    held, since = bus.record(key), time.time()
    try:
        if not poll(lambda: caught_up(bus.recorded[key], since), timeout, 0.1):
            raise TimeoutError(f"the learner {learner}'s fits still under way after {timeout:.0f} s")
        return time.time() - since
    finally:
        held.undeclare()
        del bus.recorded[key]
