"""Teachers of Gymnasium's classic control tasks, written from each task's physics (no learning):
the demonstrators a person would switch on to teach the `gym` platform's student.

Each reads the observation the gym platform gives as DL input and answers the action: a torque or
force for a continuous task, one output per action for a discrete one (1 for the chosen, 0 for the
rest: the platform takes the largest, and the student learns the choice as one-hot). Returns measured
against a random policy are in docs/results.md (`benchmarks/gym.py` prints them).
"""
from __future__ import annotations

import math

import numpy as np

from bus_schema.spaces import Spaces


def _expect(spaces: Spaces, teacher: str, n_in: int, n_out: int, env: str) -> None:
    if spaces.input.dims != n_in or spaces.output.dims != n_out:
        raise ValueError(f"the {teacher} teacher expects {n_in} inputs and {n_out} outputs ({env}'s), got "
                         f"{spaces.input.dims} and {spaces.output.dims}; run it on the gym platform with env={env}")


def _one_hot(action: int, n: int) -> np.ndarray:
    y = np.zeros(n)
    y[action] = 1.0
    return y


class PendulumTeacher:
    """Pendulum-v1 swing-up: pump energy (torque along the swing while below the upright's energy),
    then a PD catch near the top. The angle is measured from upright; the pendulum obeys
    theta'' = 3 g / (2 l) sin(theta) + 3 u / (m l^2), g = 10, m = l = 1 (gymnasium's classic_control)."""

    GRAVITY_TERM, TORQUE_GAIN, MAX_TORQUE = 15.0, 3.0, 2.0

    def __init__(self, spaces: Spaces, pump: float = 0.5, catch_angle: float = 0.6, kp: float = 10.0,
                 kd: float = 2.5):
        _expect(spaces, "pendulum", 3, 1, "Pendulum-v1")
        self.spaces, self.pump, self.catch_angle, self.kp, self.kd = spaces, pump, catch_angle, kp, kd

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, float]:
        cos_t, sin_t, rate = (float(v) for v in x)
        theta = math.atan2(sin_t, cos_t)
        if abs(theta) < self.catch_angle:
            u = -(self.kp * theta + self.kd * rate)
        else:
            # energy with the upright at rest as 0: E = rate^2 / 2 + 15 (cos - 1); dE/dt = 3 u rate
            energy = 0.5 * rate * rate + self.GRAVITY_TERM * (cos_t - 1.0)
            u = -self.pump * energy * rate if rate != 0.0 else self.MAX_TORQUE
        return self.spaces.output.clip(np.array([u])), 1.0


class CartPoleTeacher:
    """CartPole-v1: push towards where the pole falls, a linear state feedback on the pole's angle and
    rate with a weak pull of the cart back to the middle (a pole-placement gain, signs from the
    linearised cart-pole: theta'' ~ (g - F/M) / l)."""

    def __init__(self, spaces: Spaces, gains=(0.1, 0.5, 10.0, 2.0)):
        _expect(spaces, "cartpole", 4, 2, "CartPole-v1")
        self.spaces, self.gains = spaces, np.asarray(gains, dtype=np.float64)

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, float]:
        push_right = float(self.gains @ np.asarray(x, dtype=np.float64)) > 0.0
        return _one_hot(int(push_right), 2), 1.0


class MountainCarTeacher:
    """MountainCarContinuous-v0: the engine cannot climb the hill directly; push along the velocity to
    gain energy each swing (full force, from a push left at rest)."""

    def __init__(self, spaces: Spaces, force: float = 1.0):
        _expect(spaces, "mountain-car", 2, 1, "MountainCarContinuous-v0")
        self.spaces, self.force = spaces, force

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, float]:
        velocity = float(x[1])
        u = self.force if velocity > 0.0 else -self.force
        return self.spaces.output.clip(np.array([u])), 1.0


class AcrobotTeacher:
    """Acrobot-v1: pump energy into the swing with the elbow, torque against the first link's turn,
    phase-advanced by half the elbow's own rate: u = sign(elbow_rate / 2 - shoulder_rate) (the sign
    pattern of an energy pump for the underactuated double pendulum; 0.5 was the best of 0.2-0.8 on
    20 episodes). Torque -1, 0, +1 are actions 0, 1, 2."""

    def __init__(self, spaces: Spaces, elbow_share: float = 0.5):
        _expect(spaces, "acrobot", 6, 3, "Acrobot-v1")
        self.spaces, self.elbow_share = spaces, elbow_share

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, float]:
        pump = self.elbow_share * float(x[5]) - float(x[4])
        return _one_hot(2 if pump > 0.0 else 0, 3), 1.0
