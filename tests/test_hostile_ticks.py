"""Ticks from the far future (issue 12): a Command or an Input with tick 2^63-1 once held the robot
still until the platform restarted. Now the platform refuses an answer to a tick it never published,
and the arbitrator an input that jumps implausibly far; both count it, and the loop goes on.
The platform's side drives the real PlatformLoop, built by its constructor, on the fake bus."""
import logging
import time

import numpy as np
import pytest

from bus_schema import Applied, Command, InstanceKeys, decode, encode
from services.arbitration.ticks import CONFIRMING, MAX_TICK_JUMP, TickTable
from services.boxes import platform as box
from services.platforms import make_platform
from tests.fakebus import FakeSession, fake_box

FAR = 2 ** 63 - 1
KEYS = InstanceKeys("main")


def command(tick, y=(0.1, 0.2)):
    return encode(Command(tick, time.time(), np.array(y), "teacher", "teacher/t", 1.0))


@pytest.fixture
def point():
    with make_platform("point", dims=2) as robot:
        yield robot


@pytest.mark.parametrize("tick", [FAR, 3 + 10 ** 9, 4, 0])
def test_the_platform_refuses_a_command_for_a_tick_it_never_published(tick, point, caplog):
    bus = FakeSession()
    loop = box.PlatformLoop(fake_box("platform", "platform", bus=bus), point)
    for _ in range(3):
        loop.publish_input()
    with caplog.at_level(logging.WARNING, logger=loop.log.name):
        loop.on_command(KEYS.command, command(tick, (0.9, -0.9)))
    assert loop.rejects.counts == {KEYS.command: 1} and loop.box.status_report(loop.report)[0]["rejected"] == 1
    assert f"a command for tick {tick}, which this platform has not published (its last tick is 3)" in caplog.text
    assert loop.latest is None and loop.answered == set() and loop.counts["commands"] == 0
    for _ in range(3):  # the real loop goes on: each tick's command is applied, the hostile one never
        loop.on_command(KEYS.command, command(loop.tick))
        loop.advance(0.03, watchdog=0.5)
        loop.publish_input()
    applied = [decode(Applied, payload, KEYS.applied) for payload in bus.on(KEYS.applied)]
    assert [a.tick for a in applied] == [3, 4, 5] and all(np.allclose(a.y, (0.1, 0.2)) for a in applied)
    assert loop.counts["commands"] == 3 and loop.counts["held"] == 0 and loop.tick == 6


def test_the_arbitrator_refuses_an_input_far_past_the_last_and_goes_on():
    table, x = TickTable(0.02), np.zeros(2)
    table.add_input(10, 0.0, x, 0.0)
    with pytest.raises(ValueError, match="jumps"):
        table.add_input(FAR, 0.0, x, 0.0)
    table.add_input(11, 0.0, x, 0.0)
    assert [e.tick for e in table.ready(set(), 1.0)] == [10, 11]
    table.add_input(1, 0.0, x, 1.0)  # back to 1: the platform restarted
    assert [e.tick for e in table.ready(set(), 2.0)] == [1]


def test_a_platform_that_really_moved_on_is_followed_once_its_inputs_go_on_from_there():
    table, x = TickTable(0.02), np.zeros(2)
    table.add_input(10, 0.0, x, 0.0)
    far = 10 + 2 * MAX_TICK_JUMP  # the link was down for longer than an hour of ticks
    for k in range(CONFIRMING):
        with pytest.raises(ValueError):
            table.add_input(far + k, 0.0, x, 0.0)
    table.add_input(far + CONFIRMING, 0.0, x, 0.0)
    table.add_input(far + CONFIRMING + 1, 0.0, x, 0.0)
    assert [e.tick for e in table.ready(set(), 1.0)] == [10, far + CONFIRMING, far + CONFIRMING + 1]
