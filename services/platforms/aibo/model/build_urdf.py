"""Writes aibo.urdf: an ERS-7-like quadruped of primitive shapes (boxes and spheres).

Run `python -m services.platforms.aibo.model.build_urdf` after changing the figures in
dimensions.py or joints.py; the generated file is committed so loading needs no build step.
Only the feet and the torso collide: fewer contact pairs keep the physics fast and the gait
predictable, and the Aibo touches the floor with its paws anyway.
"""
from __future__ import annotations

from pathlib import Path


from services.platforms.aibo import dimensions as d
from services.platforms.aibo.joints import JOINT_LIMITS, JOINT_NAMES, LEGS

WHITE, GREY, DARK, EAR_OFF = "0.92 0.92 0.9 1", "0.55 0.56 0.58 1", "0.2 0.2 0.22 1", "0.5 0.5 0.5 1"
EFFORT, VELOCITY = 3.0, 8.0  # N m and rad/s; generous for a 1.65 kg robot (estimate)


def _xyz(v) -> str:
    return " ".join(f"{x:.5g}" for x in v)


def _box_inertia(m: float, size) -> tuple[float, float, float]:
    x, y, z = size
    return m * (y * y + z * z) / 12, m * (x * x + z * z) / 12, m * (x * x + y * y) / 12


def link(name: str, mass: float, box=None, at=(0, 0, 0), colour=GREY, collide=False, sphere=None) -> str:
    """A link with one box (and optionally a sphere, the foot) centred at `at`."""
    parts, inertia = [], (1e-6, 1e-6, 1e-6)
    if box is not None:
        geometry = f'<geometry><box size="{_xyz(box)}"/></geometry>'
        parts.append(f'<visual><origin xyz="{_xyz(at)}"/>{geometry}'
                     f'<material name="{name}"><color rgba="{colour}"/></material></visual>')
        if collide:
            parts.append(f'<collision><origin xyz="{_xyz(at)}"/>{geometry}</collision>')
        inertia = tuple(max(i, 1e-6) for i in _box_inertia(mass, box))
    if sphere is not None:
        centre, radius = sphere
        geometry = f'<geometry><sphere radius="{radius}"/></geometry>'
        parts.append(f'<visual><origin xyz="{_xyz(centre)}"/>{geometry}'
                     f'<material name="{name}_foot"><color rgba="{DARK}"/></material></visual>')
        parts.append(f'<collision><origin xyz="{_xyz(centre)}"/>{geometry}</collision>')
    ixx, iyy, izz = inertia
    inertial = (f'<inertial><origin xyz="{_xyz(at)}"/><mass value="{mass}"/>'
                f'<inertia ixx="{ixx:.3g}" iyy="{iyy:.3g}" izz="{izz:.3g}" ixy="0" ixz="0" iyz="0"/></inertial>')
    return f'<link name="{name}">{inertial}{"".join(parts)}</link>'


def joint(name: str, parent: str, child: str, xyz, axis=None) -> str:
    """A revolute joint (limits from JOINT_LIMITS) when `name` is a motor, else a fixed one."""
    if name not in JOINT_NAMES:
        return (f'<joint name="{name}" type="fixed"><parent link="{parent}"/><child link="{child}"/>'
                f'<origin xyz="{_xyz(xyz)}"/></joint>')
    lo, hi = JOINT_LIMITS[JOINT_NAMES.index(name)]
    return (f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{_xyz(xyz)}"/><axis xyz="{_xyz(axis)}"/>'
            f'<limit lower="{lo:.6f}" upper="{hi:.6f}" effort="{EFFORT}" velocity="{VELOCITY}"/>'
            f'<dynamics damping="0.01" friction="0"/></joint>')


def leg(name: str) -> list[str]:
    """Shoulder pitch about y, then roll about x, then the knee about y; all zero = leg straight down."""
    front, left = d.leg_side(name)
    shin = d.SHIN["front" if front > 0 else "rear"]
    pitch_axis = (0, -front, 0)  # positive swings the foot away from the body's middle
    roll_axis = (left, 0, 0)  # positive moves the foot outwards
    return [
        link(f"{name}_shoulder", d.MASS["shoulder"], (0.03, 0.02, 0.03), colour=WHITE),
        joint(f"{name}_shoulder_pitch", "body", f"{name}_shoulder", (front * d.SHOULDER_X, left * d.SHOULDER_Y, 0),
              pitch_axis),
        link(f"{name}_thigh", d.MASS["thigh"], (0.028, 0.024, d.THIGH), (0, 0, -d.THIGH / 2), WHITE),
        joint(f"{name}_shoulder_roll", f"{name}_shoulder", f"{name}_thigh", (0, 0, 0), roll_axis),
        link(f"{name}_shin", d.MASS["shin"], (0.02, 0.02, shin), (0, 0, -shin / 2), GREY,
             sphere=((0, 0, -shin), d.FOOT_RADIUS)),
        joint(f"{name}_knee", f"{name}_thigh", f"{name}_shin", (0, 0, -d.THIGH), pitch_axis),
    ]


def head() -> list[str]:
    """Neck tilt and pan at the neck's base, nod at its top; the nose link carries the camera
    and has no visual so that it never hides the camera's view."""
    return [
        link("neck", d.MASS["neck"] / 2, (0.02, 0.02, 0.02), colour=DARK),
        joint("head_tilt", "body", "neck", d.NECK_BASE, (0, -1, 0)),
        link("neck_column", d.MASS["neck"] / 2, (0.028, 0.028, d.NECK_LENGTH), (0, 0, d.NECK_LENGTH / 2), DARK),
        joint("head_pan", "neck", "neck_column", (0, 0, 0), (0, 0, 1)),
        link("head", d.MASS["head"], (0.095, 0.075, 0.06), (0.027, 0, 0.0), WHITE),
        joint("head_nod", "neck_column", "head", (0, 0, d.NECK_LENGTH), (0, -1, 0)),
        link("jaw", d.MASS["jaw"], (0.045, 0.04, 0.012), (0.022, 0, 0), DARK),
        joint("mouth", "head", "jaw", (0.028, 0, -0.036), (0, -1, 0)),
        link("nose", d.MASS["nose"]),
        joint("nose_camera", "head", "nose", d.NOSE),
        link("ear_left", d.MASS["ear"], (0.03, 0.006, 0.035), (0, 0, 0.015), EAR_OFF),
        joint("ear_left_mount", "head", "ear_left", (-0.005, 0.04, 0.03)),
        link("ear_right", d.MASS["ear"], (0.03, 0.006, 0.035), (0, 0, 0.015), EAR_OFF),
        joint("ear_right_mount", "head", "ear_right", (-0.005, -0.04, 0.03)),
    ]


def tail() -> list[str]:
    """Tilt about y at the rump (positive lowers the tail backwards), then pan about the tilted x."""
    return [
        link("tail_base", d.MASS["tail_base"], (0.015, 0.015, 0.015), colour=DARK),
        joint("tail_tilt", "body", "tail_base", d.TAIL_BASE, (0, -1, 0)),
        link("tail", d.MASS["tail"], (0.012, 0.012, 0.08), (0, 0, 0.04), GREY),
        joint("tail_pan", "tail_base", "tail", (0, 0, 0), (1, 0, 0)),
    ]


def urdf() -> str:
    parts = [link("body", d.MASS["body"], d.BODY_SIZE, colour=WHITE, collide=True)]
    for name in LEGS:
        parts += leg(name)
    parts += head() + tail()
    body = "\n  ".join(parts)
    return (f'<?xml version="1.0"?>\n<!-- generated by build_urdf.py; edit that, not this -->\n'
            f'<robot name="aibo_ers7">\n  {body}\n</robot>\n')


def main() -> Path:
    path = Path(__file__).with_name("aibo.urdf")
    path.write_text(urdf())
    return path


if __name__ == "__main__":
    print(main())
