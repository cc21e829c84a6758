"""Ticks from the far future (issue 12): a Command or an Input with tick 2^63-1 once held the robot
still until the platform restarted. Now the platform refuses an answer to a tick it never published,
and the arbitrator an input that jumps implausibly far; both count it, and the loop goes on."""
import collections
import logging
import time
import types

import numpy as np
import pytest

from bus_schema import Command, encode
from services.arbitration.ticks import CONFIRMING, MAX_TICK_JUMP, TickTable
from services.boxes import platform as box
from services.bus.inbox import Rejects

FAR = 2 ** 63 - 1


class Robot:
    def __init__(self):
        self.stepped = []

    def step(self, y, dt):
        self.stepped.append(np.asarray(y).copy())
        return y

    def hold(self, dt):
        self.stepped.append(None)


def platform_loop() -> box.PlatformLoop:
    """The platform service's command handling with the bus replaced."""
    loop = box.PlatformLoop.__new__(box.PlatformLoop)
    loop.platform, loop.dims, loop.log = Robot(), 2, logging.getLogger("t")
    loop.rejects, loop.counts, loop.mode = Rejects(loop.log), collections.Counter(), ""
    loop.tick, loop.latest, loop.latest_at, loop.applied_tick = 0, None, -1.0, -1
    loop.answered, loop.latencies, loop.recent_latency = set(), None, collections.deque(maxlen=10)
    loop.applied_pub = types.SimpleNamespace(put=lambda payload: None)
    loop.episodes = None  # a robot without a task's reward
    return loop


def command(tick, y=(0.1, 0.2)):
    return encode(Command(tick, time.time(), np.array(y), "teacher", "teacher/t", 1.0))


@pytest.mark.parametrize("tick", [FAR, 4, 0])
def test_the_platform_refuses_a_command_for_a_tick_it_never_published(tick):
    loop = platform_loop()
    loop.tick = 3
    loop.on_command("dl/main/command", command(tick, (9.0, 9.0)))
    assert loop.rejects.total == 1 and loop.latest is None
    for t in (3, 4, 5):  # the real loop goes on: each tick's command is applied
        loop.tick = t
        loop.on_command("dl/main/command", command(t))
        loop.advance(0.03, watchdog=0.5)
    assert loop.applied_tick == 5 and all(s is not None for s in loop.platform.stepped)
    assert loop.counts["commands"] == 3


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
