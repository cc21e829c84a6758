"""The platform box's tick accounting on a fake bus, with a real platform behind it: the answer window
stays bounded and exact, late commands count as stale, commands for ticks never published are
rejected, and with the camera as the tick (the Aibo's --input camera) ticks are settled as any others."""
import time

import numpy as np
import pytest

from bus_schema.spaces import LOCKSTEP
from bus_schema import Command, Frame, InstanceKeys, Input, RobotKeys, SpacesMessage, decode, encode
from services.boxes import platform as box
from services.boxes.aibo import AiboLoop
from services.platforms import make_platform
from tests.fakebus import FakeSession, fake_box

KEYS = InstanceKeys("main")


def command(tick: int, dims: int) -> bytes:
    return encode(Command(tick, time.time(), np.zeros(dims), "teacher", "teacher/t", 1.0))


def run(loop, ticks: int, unanswered=(), late=()):
    """Publishes `ticks` inputs; answers each at once, except the unanswered and the late (answered
    after the next input went out)."""
    dims = loop.dims
    for tick in range(1, ticks + 1):
        loop.publish_input()
        if tick - 1 in late:
            loop.on_command(KEYS.command, command(tick - 1, dims))
        if tick not in unanswered and tick not in late:
            loop.on_command(KEYS.command, command(tick, dims))
    return loop.summary()


@pytest.fixture
def point():
    with make_platform("point", dims=2) as robot:
        yield robot


def test_the_answer_window_is_exact_and_bounded(point, monkeypatch):
    monkeypatch.setattr(box, "ANSWER_WINDOW", 5)
    bus = FakeSession()
    loop = box.PlatformLoop(fake_box("platform", "platform", bus=bus), point)
    summary = run(loop, 10_000, unanswered=(3, 17, 9_999))
    assert (summary["ticks"], summary["answered"], summary["unanswered"]) == (10_000, 9_997, 3)
    assert summary["first_unanswered"] == summary["last_unanswered"] == [3, 17, 9_999]
    assert len(loop.answered) <= 5 and loop.report()[0]["lost_ticks"] == 2  # 9_999 is still in the window
    assert [decode(Input, p, KEYS.input).tick for p in bus.on(KEYS.input)] == list(range(1, 10_001))


def test_a_miss_after_a_thousand_start_up_misses_still_shows(point, monkeypatch):
    """The hot-swap test's check looked only at the first 1,000 unanswered ticks."""
    monkeypatch.setattr(box, "ANSWER_WINDOW", 5)
    loop = box.PlatformLoop(fake_box("platform", "platform"), point)
    summary = run(loop, 3_000, unanswered=(*range(1, 1_501), 2_500))
    assert summary["unanswered"] == 1_501 and max(summary["first_unanswered"]) == 1_000
    assert summary["last_unanswered"][-1] == 2_500 and len(summary["last_unanswered"]) == 1_000


def test_late_commands_count_as_stale_and_commands_for_unpublished_ticks_are_rejected(point):
    loop = box.PlatformLoop(fake_box("platform", "platform"), point)
    summary = run(loop, 50, late=(10, 20))
    assert summary["unanswered"] == 0 and loop.counts["stale_commands"] == 2
    for hostile in (0, 51, 10**9):
        loop.on_command(KEYS.command, command(hostile, loop.dims))
    assert loop.rejects.total == 3 and loop.counts["commands"] == 50 and loop.latest.tick == 50


def test_camera_ticks_are_settled_like_any_other(monkeypatch):
    """With the camera as the tick the window was never settled: after 1,000 ticks the unanswered count
    went negative and the answered set grew for ever."""
    monkeypatch.setattr(box, "ANSWER_WINDOW", 5)
    bus = FakeSession()
    robot_keys = RobotKeys("aibo")
    with make_platform("aibo", command="move") as aibo:
        loop = AiboLoop(fake_box("aibo", "aibo", bus=bus), robot_keys, aibo, "camera", 0.0)
        summary = run(loop, 40, unanswered=(4,))
    assert (summary["answered"], summary["unanswered"], summary["first_unanswered"]) == (39, 1, [4])
    assert len(loop.answered) <= 5 and loop.report()[0]["lost_ticks"] == 1
    assert bus.on(KEYS.input) == [], "perception, not the robot, publishes the input"
    assert [decode(Frame, p, robot_keys.camera).tick for p in bus.on(robot_keys.camera)] == list(range(1, 41))


def test_its_clock_on_the_runtime_waits_for_an_arbitrator_then_ticks_in_lockstep_until_the_last_is_answered(point):
    """run_ticks driven by the fake bus: no tick before a commanding arbitrator, each next tick as soon as
    the last is answered (lockstep), the spaces query answered, and the loop's end at max_ticks."""
    runtime = fake_box("platform", "platform", turns=10_000)  # (a loop that never ends fails, not hangs)
    bus = runtime.session
    loop = box.PlatformLoop(runtime, point)
    asked = []

    def arbitrate(raw):  # as the arbitrator would: each input answered at once; at tick 3 the spaces asked
        tick = decode(Input, raw, "k").tick
        asked.extend([bus.query(KEYS.spaces)] if tick == 3 else [])
        bus.deliver(KEYS.command, command(tick, 2))
    bus.respond(KEYS.input, arbitrate)
    bus.deliver_alive(KEYS.commanding("arbitrator"))  # before the loop: it hears it as history
    started = time.monotonic()
    box.run_ticks(loop, {}, rate_hz=0.0, sim_hz=30.0, watchdog=5.0, max_ticks=20)
    took = time.monotonic() - started
    summary = loop.summary()
    assert (summary["ticks"], summary["answered"], summary["unanswered"], summary["applied"]) == (20, 20, 0, 19)
    assert box.SUBSCRIPTION_SETTLE_S <= took < box.SUBSCRIPTION_SETTLE_S + 2.0, "lockstep: no watchdog waits"
    assert not runtime.stop, "ended by its last tick, not stopped"
    [(key, payload)] = asked[0].replies
    # the spaces as the platform's, and said to be in lockstep: its arbitrator waits LOCKSTEP_DEADLINE_MS
    served = decode(SpacesMessage, payload, key).spaces
    assert key == KEYS.spaces and served == {**point.spaces.to_dict(), "extra": {**point.spaces.extra, LOCKSTEP: True}}
