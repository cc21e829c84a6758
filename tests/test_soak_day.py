"""The soak's scripted day (rigs/soak/day.py) as data: what happens when, for the hour, for a
quarter of it and for --quick."""
import random

import pytest

from rigs.soak.day import DISRUPTIVE, kill_order, pace, day

SERVICES = ["router", "recorder", "aibo", "handler", "mirror", "learner", "arbitrator", "ui"]
OTHERS = ["knn", "lwpr", "sogp", "gp"]


def events(hours=1.0, quick=False):
    return day(pace(hours, quick), ("mirror", "remote"), SERVICES, OTHERS, "per-output:base=gp")


@pytest.mark.parametrize("hours, quick", [(1.0, False), (0.25, False), (3.0, False), (0.0, True)])
def test_the_day_ends_alone_with_the_wired_learner_left_in_peace(hours, quick):
    day_events, p = events(hours, quick), pace(hours, quick)
    alone = [e for e in day_events if e.kind == "alone"]
    assert alone[-1].arg == (False,) and alone[-1].at == pytest.approx(p.length_s, abs=p.lesson_s)
    last_alone = alone[-2].at
    swaps = [e.arg[0] for e in day_events if e.kind == "swap"]
    cycle = OTHERS + ["per-output:base=gp"]
    rounds = len(swaps) // len(cycle)
    assert swaps[-1] == "per-output:base=gp" and swaps[:rounds * len(cycle)] == cycle * rounds
    tail = swaps[rounds * len(cycle):]
    assert not tail or tail == OTHERS[:len(tail) - 1] + ["per-output:base=gp"]
    assert all(e.at < last_alone - p.lesson_s for e in day_events if e.kind in DISRUPTIVE)


def test_the_hour_holds_what_the_issue_asks():
    day_events = events()
    count = {kind: sum(1 for e in day_events if e.kind == kind) for kind in DISRUPTIVE + ("cut", "drive")}
    assert count["kill"] >= 11 and count["swap"] == 5 and count["stranger"] >= 5 and count["fill"] == 1
    assert sum(1 for e in events(3.0) if e.kind == "swap") >= 15  # longer days go round the learners again
    assert count["cut"] >= 3 and count["drive"] >= 3
    teachers = {e.arg[0] for e in day_events if e.kind == "teach"}
    assert teachers == {"mirror", "remote"}
    disruptive = [e.at for e in day_events if e.kind in DISRUPTIVE]
    assert min(b - a for a, b in zip(disruptive, disruptive[1:])) >= pace(1.0, False).spacing_s


def test_quick_kills_the_router_and_the_recorder_and_swaps_through_two_others_and_back():
    day_events = events(quick=True)
    assert [e.arg[0] for e in day_events if e.kind == "kill"][:2] == ["router", "recorder"]
    assert [e.arg[0] for e in day_events if e.kind == "swap"] == ["knn", "lwpr", "per-output:base=gp"]
    assert {"stranger", "fill", "free", "cut", "heal", "drive"} <= {e.kind for e in day_events}


def test_every_service_is_killed_as_often_as_any_other():
    order = kill_order(SERVICES, 5 * len(SERVICES), random.Random(0))
    assert order[:2] == ["router", "recorder"]
    assert {order.count(s) for s in SERVICES} == {5}


def test_the_first_and_last_spells_alone_share_their_arena():
    arenas = {e.at: e.arg[0] for e in events() if e.kind == "arena"}
    alone = [e.at for e in events() if e.kind == "alone" and e.arg == (True,)]
    spell = pace(1.0, False).lesson_s
    first, last = (max(t for t in arenas if t <= a) for a in (alone[0], alone[-1]))
    assert arenas[first] == arenas[last] and first != last and alone[0] - first < spell


def test_a_day_too_short_for_a_lesson_is_refused():
    with pytest.raises(ValueError, match="--hours must be > 0"):
        pace(0.0, False)


@pytest.mark.parametrize("hours, quick", [(1.0, False), (0.25, False), (0.0, True)])
def test_the_last_lesson_waits_for_the_last_swap_after_the_spell_before_it_closed(hours, quick):
    day_events = events(hours, quick)
    holds = [i for i, e in enumerate(day_events) if e.kind == "hold"]
    assert len(holds) == 1
    hold = day_events[holds[0]]
    last_lesson = [e for e in day_events if e.kind == "teach" and e.arg[1]][-1]
    assert hold.at == last_lesson.at and day_events.index(last_lesson) > holds[0]
    before = day_events[:holds[0]]
    assert [e.arg for e in before if e.kind == "alone"][-1] == (False,)  # no span open while it waits
    assert [e for e in before if e.kind == "arena"][-1].at == hold.at
    assert all(e.at < hold.at for e in day_events if e.kind == "swap")
