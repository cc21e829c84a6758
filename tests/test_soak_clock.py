"""The soak's day clock (rigs/soak/driver.take_due): events come due in order, and at a `hold` the clock
stands still while a swap is under way, every later event moving on by the wait."""
from rigs.soak.day import Event
from rigs.soak.driver import take_due


def due(queue, now, held, swapping):
    out = []
    while True:
        event, held = take_due(queue, now, held, swapping)
        if event is None:
            return out, held
        out.append(event.kind)


def test_events_come_due_in_order_and_none_early():
    queue = [Event(1.0, "teach"), Event(2.0, "alone"), Event(5.0, "kill")]
    assert due(queue, 2.5, 0.0, False) == (["teach", "alone"], 0.0)
    assert due(queue, 4.9, 0.0, False) == ([], 0.0)
    assert due(queue, 5.0, 0.0, False) == (["kill"], 0.0)


def test_a_hold_stops_the_clock_while_a_swap_is_under_way_and_moves_the_rest_on():
    queue = [Event(5.0, "teach"), Event(10.0, "hold"), Event(10.0, "teach"), Event(20.0, "alone")]
    assert due(queue, 12.0, 0.0, True) == (["teach"], 2.0)
    assert due(queue, 300.0, 2.0, True) == ([], 290.0)  # still swapping: still held
    done, held = due(queue, 301.0, 290.0, False)
    assert (done, held) == (["hold", "teach"], 290.0)
    assert due(queue, 309.9, held, False) == ([], 290.0)  # the spell after it keeps its length
    assert due(queue, 310.0, held, False) == (["alone"], 290.0)


def test_a_hold_with_no_swap_under_way_costs_nothing():
    queue = [Event(10.0, "hold"), Event(10.0, "teach")]
    assert due(queue, 10.0, 0.0, False) == (["hold", "teach"], 0.0)
