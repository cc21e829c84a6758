"""The walk level's demonstrator: the hand-coded trot (services/platforms/aibo/gait.py) as a
function of a movement command and the gait's phase, answering 12 leg joint targets.

It finds its inputs by name (`forward`, `turn`, `phase_sin`, `phase_cos`, wherever the chain put
them), so the same teacher serves a walk level fed by any upper level that asks for movements.
With stand=True it answers the standing pose whatever is asked: the walk level's default
controller (--role default), so that an untaught or unsure walk level stands rather than
putting its legs mid-range (a heap on the floor).
"""
from __future__ import annotations

import numpy as np

from bus_schema.spaces import Spaces
from services.platforms.aibo.gait import TrotGait

INPUT_NAMES = ("forward", "turn", "phase_sin", "phase_cos")
LEG_TARGETS = 12


class TrotTeacher:
    def __init__(self, spaces: Spaces, stand: bool = False, **gait_params):
        names = tuple(spaces.input.names)
        missing = [name for name in INPUT_NAMES if name not in names]
        if missing:
            raise ValueError(f"the trot teacher needs inputs named {', '.join(INPUT_NAMES)}; "
                             f"missing {', '.join(missing)} among {', '.join(names)}")
        if spaces.output.dims != LEG_TARGETS:
            raise ValueError(f"the trot teacher answers {LEG_TARGETS} leg joint targets, but the output space "
                             f"has {spaces.output.dims} ({', '.join(spaces.output.names)})")
        if not isinstance(stand, bool):
            raise ValueError(f"stand must be true or false, got {stand!r}")
        self.spaces, self.gait = spaces, TrotGait(**gait_params)
        self.standing = spaces.output.clip(self.gait.stand_pose()) if stand else None  # whatever the phase
        self.at = [names.index(name) for name in INPUT_NAMES]

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray | None, float]:
        if self.standing is not None:
            return self.standing.copy(), 1.0
        forward, turn, sin, cos = (float(x[i]) for i in self.at)
        phase = (np.arctan2(sin, cos) / (2 * np.pi)) % 1.0
        return self.spaces.output.clip(self.gait.pose_at(forward, turn, phase)), 1.0
