"""Teachers by name. A teacher is called with an input and answers (output or None, confidence).

Constructor: `Cls(spaces, **params)`, so a teacher knows the dims and bounds but not the task's
meaning beyond what its own code says. Pure Python: no bus.
"""
from __future__ import annotations

import importlib

TEACHERS: dict[str, str] = {
    "sine": "services.teachers.functions:SineTeacher",
    "copy": "services.teachers.functions:CopyTeacher",
    "mirror": "services.teachers.functions:MirrorTeacher",
    "hold": "services.teachers.functions:HoldTeacher",
    "ballseek": "services.teachers.ballseek:ball_seek_teacher",  # either blob layout, from the input names
    "random-map": "services.teachers.random_map:RandomMapTeacher",  # a smooth map nobody designed, from a seed
    "trot": "services.teachers.trot:TrotTeacher",  # the walk level: movement and gait phase -> 12 leg targets
    "wander": "services.teachers.wander:WanderTeacher",  # a handler asking for random outputs, held a while
    # Gymnasium's classic control tasks on the gym platform, from their physics
    "pendulum": "services.teachers.classic_control:PendulumTeacher",
    "cartpole": "services.teachers.classic_control:CartPoleTeacher",
    "mountain-car": "services.teachers.classic_control:MountainCarTeacher",
    "acrobot": "services.teachers.classic_control:AcrobotTeacher",
}


def teacher_class(name: str) -> type:
    if name not in TEACHERS:
        raise KeyError(f"unknown teacher {name!r}; known: {', '.join(sorted(TEACHERS))}")
    module, cls = TEACHERS[name].split(":")
    return getattr(importlib.import_module(module), cls)


def make_teacher(name: str, spaces, **params):
    return teacher_class(name)(spaces, **params)
