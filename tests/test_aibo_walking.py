"""Walking on the physics (acceptance 3): the trot moves the body through its feet.

Forward at least 0.5 m in 10 s of simulated time; turns of at least 45 degrees each way in
10 s; two simulated minutes of random movement commands without falling over.
"""
from __future__ import annotations

import numpy as np
import pytest

from services.platforms.aibo.gait import MOVE_LIMITS
from services.platforms.aibo.sim import AiboSim

CONTROL_DT = 0.05


def walk(sim: AiboSim, forward: float, turn: float, seconds: float) -> tuple[float, float, float]:
    """(distance m, yaw change rad, lowest uprightness) over `seconds` of walking."""
    start, yaw, turned, lowest = sim.base_pose()[0], sim.base_yaw(), 0.0, 1.0
    sim.set_movement(forward, turn)
    for _ in range(round(seconds / CONTROL_DT)):
        sim.step(CONTROL_DT)
        now = sim.base_yaw()
        turned += (now - yaw + np.pi) % (2 * np.pi) - np.pi  # unwrap across +-pi
        yaw, lowest = now, min(lowest, sim.upright())
    return float(np.hypot(*(sim.base_pose()[0] - start)[:2])), turned, lowest


def test_forward_command_walks_half_a_metre_in_ten_seconds():
    with AiboSim(seed=0) as sim:
        base_z = sim.base_pose()[0][2]
        distance, _, lowest = walk(sim, MOVE_LIMITS[0, 1], 0.0, 10.0)
        assert distance >= 0.5
        assert lowest > 0.9 and sim.base_pose()[0][2] > 0.8 * base_z


@pytest.mark.parametrize("direction", [1, -1], ids=["left", "right"])
def test_turn_command_turns_45_degrees_in_ten_seconds(direction):
    with AiboSim(seed=0) as sim:
        _, turned, lowest = walk(sim, 0.0, direction * MOVE_LIMITS[1, 1], 10.0)
        assert direction * turned >= np.radians(45)
        assert lowest > 0.9


@pytest.mark.slow
def test_two_minutes_of_random_commands_without_falling():
    rng = np.random.default_rng(0)
    with AiboSim(seed=1) as sim:
        base_z = sim.base_pose()[0][2]
        lowest, lowest_z = 1.0, base_z
        while sim.sim_time < 120.0:
            sim.set_movement(*rng.uniform(MOVE_LIMITS[:, 0], MOVE_LIMITS[:, 1]))
            for _ in range(round(rng.uniform(0.5, 3.0) / CONTROL_DT)):
                sim.step(CONTROL_DT)
                lowest, lowest_z = min(lowest, sim.upright()), min(lowest_z, sim.base_pose()[0][2])
        assert sim.sim_time >= 120.0
        assert lowest > 0.8, "the body tilted more than ~37 degrees"
        assert lowest_z > 0.7 * base_z, "the body sank towards the floor"
