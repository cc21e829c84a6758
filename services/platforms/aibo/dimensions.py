"""ERS-7 body figures in metres and kilograms, shared by the URDF generator and the gait.

Lengths follow the ERS-7 kinematic chain published with Sony's OPEN-R model information
(as reproduced in Tekkotsu's ERS-7.kin); box sizes and the split of the mass are estimates
chosen so that the whole robot weighs the catalogue's ~1.65 kg. Details in model/README.md.
"""
from __future__ import annotations

SHOULDER_X = 0.065  # shoulders and hips sit +-65 mm along the body from its centre
SHOULDER_Y = 0.0625  # and +-62.5 mm to each side
THIGH = 0.0695  # shoulder to knee
SHIN = {"front": 0.0654, "rear": 0.0676}  # knee to the centre of the ball of the foot
FOOT_RADIUS = 0.012  # the ball of the foot, ~24 mm across

BODY_SIZE = (0.20, 0.11, 0.08)  # torso box, x forward, y left, z up (estimate)
NECK_BASE = (0.0675, 0.0, 0.0195)  # neck tilt axis, from the body centre
NECK_LENGTH = 0.080  # neck tilt to head nod axis
NOSE = (0.081, 0.0, -0.0146)  # camera, from the nod axis
TAIL_BASE = (-0.102, 0.0, 0.033)

MASS = {  # kg; ~1.65 kg in all, the ERS-7 catalogue weight with battery
    "body": 0.95, "shoulder": 0.015, "thigh": 0.06, "shin": 0.045,
    "neck": 0.04, "head": 0.14, "jaw": 0.015, "nose": 0.002, "ear": 0.003,
    "tail_base": 0.005, "tail": 0.015,
}


def leg_side(leg: str) -> tuple[int, int]:
    """(+1 front / -1 rear, +1 left / -1 right) for a leg named fl, fr, rl or rr."""
    return (1 if leg[0] == "f" else -1), (1 if leg[1] == "l" else -1)


def total_mass() -> float:
    per_leg = MASS["shoulder"] + MASS["thigh"] + MASS["shin"]
    return 4 * per_leg + sum(MASS[k] for k in ("body", "neck", "head", "jaw", "nose", "tail_base",
                                               "tail")) + 2 * MASS["ear"]
