"""A handler: a person moving some of the robot's joints by hand, as in the paper's mirroring task.

Pure functions of time and seed (no simulator): the tail follows a smooth trajectory that
sweeps its whole range, and chosen other motors wander randomly as distractors, so a learner
must find out that only the tail matters. `Handler.at(t)` gives (mask, q): the joints handled
and where they are held; `AiboSim.set_handled(mask, q)` makes them follow.
"""
from __future__ import annotations

import numpy as np

from services.platforms.aibo.gait import neutral_pose
from services.platforms.aibo.joints import JOINT_INDEX, JOINT_LIMITS, JOINT_NAMES, TAIL_PAN, TAIL_TILT

TAIL = ("tail_tilt", "tail_pan")
OTHER_16 = tuple(name for name in JOINT_NAMES if name not in TAIL)
# the mirroring task commands the head, so a handler for it must leave the head alone
MIRRORING_DISTRACTORS = tuple(name for name in OTHER_16 if not name.startswith("head_"))


def tail_trajectory(t: float, seed: int = 0, period: float = 6.0) -> np.ndarray:
    """(tilt, pan) at time t: two sines per joint at incommensurate rates (a Lissajous figure
    that fills the tail's rectangle of limits over a minute or so), 5% inside each limit."""
    rng = np.random.default_rng([seed, 7])
    rates = rng.uniform(0.7, 1.3, size=(2, 2)) / period
    phases = rng.uniform(0, 2 * np.pi, size=(2, 2))
    wave = 0.5 * np.sin(2 * np.pi * rates * t + phases).sum(axis=1)  # in [-1, 1]
    low, high = JOINT_LIMITS[[TAIL_TILT, TAIL_PAN], 0], JOINT_LIMITS[[TAIL_TILT, TAIL_PAN], 1]
    return (low + high) / 2 + 0.95 * (high - low) / 2 * wave


class Handler:
    """Tail along `tail_trajectory`; `distractors` (joint names) move between random waypoints,
    a new one every `segment` seconds, within `amplitude` of each joint's half-range around rest."""

    def __init__(self, seed: int = 0, tail: bool = True, distractors: tuple[str, ...] = OTHER_16,
                 tail_period: float = 6.0, segment: float = 1.5, amplitude: float = 0.3):
        unknown = set(distractors) - set(JOINT_NAMES)
        if unknown:
            raise ValueError(f"unknown joints {sorted(unknown)}; names are services.platforms.aibo.JOINT_NAMES")
        self.seed, self.tail, self.distractors = seed, tail, tuple(distractors)
        self.tail_period, self.segment, self.amplitude = tail_period, segment, amplitude
        self._rest = neutral_pose()
        self._moving = np.array([JOINT_INDEX[name] for name in self.distractors], dtype=int)

    @property
    def mask(self) -> np.ndarray:
        mask = np.zeros(len(JOINT_NAMES), dtype=bool)
        mask[self._moving] = True
        if self.tail:
            mask[[TAIL_TILT, TAIL_PAN]] = True
        return mask

    def _waypoint(self, k: int) -> np.ndarray:
        """Waypoint k for every joint, drawn from its own seed so any time can be asked in any order."""
        u = np.random.default_rng([self.seed, 11, k]).uniform(-1.0, 1.0, size=len(JOINT_NAMES))
        half = (JOINT_LIMITS[:, 1] - JOINT_LIMITS[:, 0]) / 2
        return np.clip(self._rest + self.amplitude * half * u, JOINT_LIMITS[:, 0], JOINT_LIMITS[:, 1])

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(mask, q) at time t seconds: joints handled, and all 18 positions (rest where unhandled)."""
        q = self._rest.copy()
        if len(self._moving):
            k, s = divmod(max(t, 0.0) / self.segment, 1.0)
            blend = (1 - np.cos(np.pi * s)) / 2  # smooth start and stop at each waypoint
            path = (1 - blend) * self._waypoint(int(k)) + blend * self._waypoint(int(k) + 1)
            q[self._moving] = path[self._moving]
        if self.tail:
            q[[TAIL_TILT, TAIL_PAN]] = tail_trajectory(t, self.seed, self.tail_period)
        return self.mask, q
