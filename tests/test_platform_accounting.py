"""The platform's tick accounting stays bounded and exact over long runs (unit test, no bus)."""
import collections
import types

from services.boxes import platform as box


def test_unanswered_ticks_counted_exactly_with_a_bounded_window(monkeypatch):
    monkeypatch.setattr(box, "ANSWER_WINDOW", 5)
    loop = box.PlatformLoop.__new__(box.PlatformLoop)  # the accounting alone, without a session
    loop.tick, loop.answered, loop.n_answered, loop.unanswered, loop.n_unanswered = 0, set(), 0, [], 0
    loop.counts, loop.rejects = collections.Counter(), types.SimpleNamespace(total=0)
    for tick in range(1, 10_001):
        loop.tick = tick
        loop._settle(tick - box.ANSWER_WINDOW)
        if tick not in (3, 17, 9_999):
            loop.answered.add(tick)
    summary = loop.summary()
    assert (summary["answered"], summary["unanswered"]) == (9_997, 3)
    assert summary["first_unanswered"] == [3, 17, 9_999]
    assert len(loop.answered) <= box.ANSWER_WINDOW
