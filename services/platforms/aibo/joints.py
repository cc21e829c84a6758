"""The Aibo's 18 motors: names, order and limits (radians), importable without pybullet.

Limits are the ERS-7 software ranges as published with Sony's OPEN-R model information
(reproduced in Tekkotsu's ERS7Info.h `outputRanges`); see model/README.md for signs.
"""
from __future__ import annotations

import numpy as np

LEGS = ("fl", "fr", "rl", "rr")
LEG_JOINTS = ("shoulder_pitch", "shoulder_roll", "knee")

JOINT_NAMES: tuple[str, ...] = tuple(f"{leg}_{joint}" for leg in LEGS for joint in LEG_JOINTS) + (
    "head_tilt", "head_pan", "head_nod", "mouth", "tail_tilt", "tail_pan",
)
JOINT_INDEX = {name: i for i, name in enumerate(JOINT_NAMES)}
LEG_SLICE = slice(0, 12)
HEAD_TILT, HEAD_PAN, HEAD_NOD, MOUTH, TAIL_TILT, TAIL_PAN = range(12, 18)

_DEGREES = {
    # shoulder pitch ("rotator"): positive swings the leg away from the body's middle
    # (front legs forward, rear legs backward), hence the mirrored ranges
    "front_shoulder_pitch": (-115.0, 130.0),
    "rear_shoulder_pitch": (-130.0, 115.0),
    "shoulder_roll": (-10.0, 88.0),  # positive abducts (foot away from the body)
    "knee": (-25.0, 122.0),  # positive bends
    "head_tilt": (-75.0, 0.0),  # positive looks up
    "head_pan": (-88.0, 88.0),  # positive looks left
    "head_nod": (-15.0, 45.0),  # positive looks up
    "mouth": (-55.0, -3.0),  # negative opens
    "tail_tilt": (5.0, 60.0),  # positive lowers the tail
    "tail_pan": (-45.0, 45.0),  # positive points the tail to the robot's right
}


def _limits_degrees(name: str) -> tuple[float, float]:
    leg, _, joint = name.partition("_")
    if leg in LEGS:
        if joint == "shoulder_pitch":
            return _DEGREES[("front_" if leg[0] == "f" else "rear_") + joint]
        return _DEGREES[joint]
    return _DEGREES[name]


JOINT_LIMITS = np.radians([_limits_degrees(name) for name in JOINT_NAMES])
JOINT_LIMITS.flags.writeable = False  # a shared constant: nobody may edit it in place
