"""services.waiting.poll: the one wait helper."""
import itertools
import time

from services.waiting import poll


def test_returns_the_first_truthy_value():
    counter = itertools.count()
    assert poll(lambda: next(counter) >= 3 and "ready", 5.0, 0.001) == "ready"


def test_gives_up_at_the_deadline_with_none_after_asking_at_least_once():
    asked = []
    started = time.monotonic()
    assert poll(lambda: asked.append(1), 0.0) is None
    assert poll(lambda: 0, 0.05, 0.01) is None
    assert len(asked) == 1 and time.monotonic() - started < 1.0


def test_stops_asking_once_told_to_stop():
    asked = []
    assert poll(lambda: asked.append(1), 60.0, 0.001, stop=True) is None
    assert asked == [1]
