"""Inbox, the one queue every box reads its bus events from: drain, and its byte budget."""
import threading
import time

import pytest

from services.bus.inbox import ITEM_OVERHEAD, Inbox


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


def test_past_its_byte_budget_an_inbox_drops_on_arrival_counts_and_takes_again_once_drained(caplog):
    inbox = Inbox(max_bytes=3 * (1000 + ITEM_OVERHEAD))
    for i in range(5):
        inbox.put(("t", f"k{i}", b"x" * 1000, None))
    assert inbox.dropped == 2 and inbox.held_bytes == 3 * (1000 + ITEM_OVERHEAD)
    with caplog.at_level("WARNING"):
        assert [item[1] for item in inbox.drain(0.0)] == ["k0", "k1", "k2"]  # the first come are kept
    assert inbox.held_bytes == 0
    assert "2 messages dropped on arrival" in caplog.text
    inbox.put(("t", "again", b"x" * 1000, None))
    assert [item[1] for item in inbox.drain(0.0)] == ["again"] and inbox.dropped == 2


def test_the_budget_holds_under_callbacks_from_many_threads():
    inbox = Inbox(max_bytes=50_000)
    sent, taken = 8 * 2000, []

    def send():
        for _ in range(2000):
            inbox.put(("t", "k", b"x" * 100, None))

    threads = [threading.Thread(target=send) for _ in range(8)]
    for t in threads:
        t.start()
    while any(t.is_alive() for t in threads) or inbox.held_bytes:
        taken.extend(inbox.drain(0.001))
        assert inbox.held_bytes <= 50_000
    assert len(taken) + inbox.dropped == sent and inbox.held_bytes == 0


def test_an_inbox_without_a_budget_is_refused():
    with pytest.raises(ValueError, match="byte budget"):
        Inbox(max_bytes=0)
