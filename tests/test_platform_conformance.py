"""Every registered platform passes every conformance check; the checker catches broken platforms."""
from __future__ import annotations

import atexit
import functools
import json
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

from bus_schema.spaces import Box, Spaces
from services.platforms import PLATFORMS, make_platform
from services.platforms.checks import ALL_CHECKS, check_step_clips_command, check_watchdog_holds_still
from services.platforms.point import PointPlatform


def a_recorded_run() -> str:
    """A short recording of the point platform (inputs and spaces), for the recorded platform."""
    from bus_schema import Input, encode
    from services.recording.writer import RunWriter
    point, folder = PointPlatform(dims=2, seed=0), Path(tempfile.mkdtemp(prefix="dogged-recorded-"))
    atexit.register(shutil.rmtree, folder, True)
    writer = RunWriter(folder, "recorder", 10**9, 3600.0)
    writer.add_metadata("spaces dl/main", {"spaces": json.dumps(point.spaces.to_dict())})
    for tick in range(1, 201):
        writer.write("dl/main/input", Input, encode(Input(tick, tick / 30, point.observe())), tick, tick)
        point.step(np.full(2, 0.5), 1 / 30)
    writer.close()
    return str(folder)

# every registered platform, plus the Aibo's other command modes; cameras off: the checks are
# about the contract, not the frames
VARIANTS = {name: (name, {}) for name in PLATFORMS}
VARIANTS["aibo"] = ("aibo", {"camera": False})
VARIANTS["aibo-move"] = ("aibo", {"camera": False, "command": "move"})
VARIANTS["aibo-legs"] = ("aibo", {"camera": False, "command": "legs", "inputs": "phase"})
VARIANTS["recorded"] = ("recorded", {"run": a_recorded_run()})
# the gym platform on every environment its teachers are written for (Box and Discrete actions)
VARIANTS["gym"] = ("gym", {"env": "Pendulum-v1"})
for env in ("CartPole-v1", "MountainCarContinuous-v0", "Acrobot-v1"):
    VARIANTS[f"gym-{env.split('-v')[0].lower()}"] = ("gym", {"env": env})


CASES = [(variant, check) for variant in sorted(VARIANTS) for check in ALL_CHECKS]


@pytest.mark.parametrize(("name", "check"), CASES, ids=[f"{name}:{check.__name__}" for name, check in CASES])
def test_platform_passes_check(name, check):
    platform, params = VARIANTS[name]
    check(functools.partial(make_platform, platform, **params))


class UnclippedPoint(PointPlatform):
    """Broken on purpose: reports the command as received, not as applied."""

    def step(self, command, dt):
        super().step(command, dt)
        return np.asarray(command, dtype=np.float64)


class DriftingPoint(PointPlatform):
    """Broken on purpose: the watchdog keeps following the last command."""

    def step(self, command, dt):
        self._last = np.asarray(command, dtype=np.float64)
        return super().step(command, dt)

    def hold(self, dt):
        super().step(self._last, dt)


def test_checker_catches_unclipped_report():
    with pytest.raises(AssertionError) as failure:
        check_step_clips_command(lambda seed: UnclippedPoint(dims=2, seed=seed))
    assert str(failure.value).startswith("step() reported [")
    assert str(failure.value).endswith("; report the command clipped to spaces.output, as applied")


def test_checker_catches_watchdog_that_keeps_moving():
    with pytest.raises(AssertionError) as failure:
        check_watchdog_holds_still(lambda seed: DriftingPoint(dims=2, seed=seed))
    message = str(failure.value)
    assert message.startswith("hold() let ['position0', 'position1'] move by [")
    assert message.endswith("; the watchdog must keep the robot still when commands stop")


class SwayingPoint(PointPlatform):
    """Declares a settle time, then sways on while held: the settle must not excuse it."""
    hold_settle_seconds = 0.5

    def hold(self, dt):
        super().hold(dt)
        self._position = self.spaces.output.clip(self._position + 0.5 * dt * np.cos(np.pi * self._time))


def test_a_declared_settle_time_does_not_excuse_a_watchdog_that_keeps_moving():
    with pytest.raises(AssertionError, match="the watchdog must keep the robot still"):
        check_watchdog_holds_still(lambda seed: SwayingPoint(dims=2, seed=seed))


def test_checker_rejects_a_settle_time_beyond_the_bound():
    class Sluggish(PointPlatform):
        hold_settle_seconds = 3.0
    with pytest.raises(AssertionError, match="hold_settle_seconds is 3.0; declare a number of seconds from 0 to 0.5"):
        check_watchdog_holds_still(lambda seed: Sluggish(dims=2, seed=seed))


def test_spaces_round_trip_used_by_checker():
    spaces = Spaces(Box.uniform(2, -1, 1, "x"), Box.uniform(1, 0, 1, "u"), {"k": 1})
    assert Spaces.from_dict(spaces.to_dict()) == spaces


def test_checker_names_what_a_platform_lacks_of_the_contract():
    from services.platforms.checks import check_spaces_declared_as_data

    class NoWatchdog:  # a platform with no hold(): the watchdog would have nothing to call
        def __init__(self, seed=0):
            self.inner = PointPlatform(dims=2, seed=seed)
            self.spaces = self.inner.spaces
            self.reset, self.observe, self.step, self.close = (self.inner.reset, self.inner.observe,
                                                               self.inner.step, self.inner.close)
    with pytest.raises(AssertionError, match="NoWatchdog lacks hold of the Platform contract"):
        check_spaces_declared_as_data(NoWatchdog)
