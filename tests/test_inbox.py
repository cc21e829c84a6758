"""Inbox.drain, the one loop every box reads its bus events with."""
import threading
import time

from services.bus.inbox import Inbox


def test_drain_waits_for_a_first_item_then_takes_what_is_queued_without_waiting():
    inbox = Inbox()
    started = time.monotonic()
    assert list(inbox.drain(0.2)) == [] and time.monotonic() - started >= 0.19
    for i in range(3):
        inbox.put(("t", f"k{i}", b"", None))
    assert [item[1] for item in inbox.drain(5.0)] == ["k0", "k1", "k2"]
    threading.Timer(0.1, inbox.put, args=(("t", "late", b"", None),)).start()
    started = time.monotonic()
    assert [item[1] for item in inbox.drain(5.0)] == ["late"] and time.monotonic() - started < 2.0
