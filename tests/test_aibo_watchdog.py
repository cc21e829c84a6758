"""The watchdog (platform.hold) stops a walking robot and keeps a posed robot still."""
from __future__ import annotations

import numpy as np
import pytest

from services.platforms.aibo.platform import AiboPlatform


def base_speed(platform: AiboPlatform, seconds: float = 1.0) -> float:
    start = platform.sim.base_pose()[0]
    platform.hold(seconds)
    return float(np.hypot(*(platform.sim.base_pose()[0] - start)[:2]) / seconds)


def test_watchdog_stops_a_walking_robot():
    with AiboPlatform(seed=0, command="move", camera=False) as platform:
        platform.reset()
        for _ in range(40):
            platform.step(np.array([0.15, 0.0]), 0.05)
        start = platform.sim.base_pose()[0]
        platform.step(np.array([0.15, 0.0]), 0.5)
        walking = float(np.hypot(*(platform.sim.base_pose()[0] - start)[:2]) / 0.5)
        platform.hold(0.5)  # the body may coast for a moment
        held = platform.observe()
        assert walking > 0.04
        assert base_speed(platform, 2.0) < 0.003
        assert np.abs(platform.observe() - held).max() < 0.01


@pytest.mark.parametrize("seed", [0, 1])
def test_a_held_robot_stands_on_four_paws_and_stays_put(seed):
    """Stopped mid-stride, a trot stands on two diagonal paws: held that way it rocked and slid
    (1-3 mm/s). The watchdog puts the feet down instead, and the paws hold on the floor."""
    rng = np.random.default_rng(seed)
    with AiboPlatform(seed=seed, command="move", camera=False) as platform:
        platform.reset()
        for _ in range(60):
            platform.step(np.array([0.15, rng.uniform(-0.8, 0.8)]), 0.05)
        platform.hold(1.0)
        assert platform.sim.paws_on_floor() == ("fl", "fr", "rl", "rr")
        assert base_speed(platform, 10.0) < 1e-4


def test_watchdog_keeps_joints_where_commands_left_them():
    rng = np.random.default_rng(0)
    with AiboPlatform(seed=0, command="joints", camera=False) as platform:
        low, high = np.array(platform.spaces.output.low), np.array(platform.spaces.output.high)
        platform.reset()
        platform.step(rng.uniform(low, high), 0.02)  # moving fast towards a random pose
        platform.hold(0.3)
        held = platform.observe()
        for _ in range(20):
            platform.hold(0.05)
        assert np.abs(platform.observe() - held).max() < 0.01
