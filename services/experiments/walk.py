"""The walk level on the physics, in one process: a handler asks for a variety of movements while
the hand-coded trot (the `trot` teacher) teaches a learner the 12 leg targets from (forward, turn,
gait phase); then the learned gait walks alone. The spaces are the ones the live chain builds
(services/chaining.py, as services/boxes/chain.py does), so what is taught here is what
deploy/hierarchy.toml teaches.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bus_schema import Spaces
from services.chaining import Easing, lower_spaces
from services.learners import DEFAULT_LEARNER, Learner, make_learner
from services.platforms.aibo.platform import LEGS_BOX, MOVE_BOX, PHASE_BOX, AiboPlatform
from services.teachers.trot import TrotTeacher

WALK_RATE_HZ = 60.0  # the walk level's ticks: at 50 Hz this trot's forward walk lost half its reach
ASK_EVERY_S = 1.5  # the handler asks for a new movement this often while teaching
EASE_S = 0.25  # the chain eases each new movement in over this (deploy/hierarchy.toml: --ease 0.25)


@dataclass
class Walked:
    distance_m: float  # straight-line distance of the body from where it started
    turned_rad: float  # yaw change, unwrapped (left positive)
    lowest_upright: float  # the body's worst tilt cosine (1 level, 0 on its side)


def walk_spaces() -> Spaces:
    """The walk level's spaces as the chain builds them from the legged robot's (input the gait clock,
    output the legs; it offers MOVE_BOX): the movement asked, then the gait clock -> 12 legs."""
    robot = Spaces(PHASE_BOX, LEGS_BOX)
    return lower_spaces(Spaces(PHASE_BOX, MOVE_BOX), robot, robot)  # the upper's output is the movement


def legged_robot(seed: int = 0) -> AiboPlatform:
    return AiboPlatform(seed=seed, command="legs", camera=False, inputs="phase")


def asked_movements(seed: int):
    """A handler's requests: a new movement every ASK_EVERY_S, each axis still 30 % of the time."""
    rng = np.random.default_rng(seed)
    low, high = np.asarray(MOVE_BOX.low), np.asarray(MOVE_BOX.high)
    while True:
        asked = rng.uniform(low, high)
        asked[rng.random(2) < 0.3] = 0.0
        yield asked


def teach_walk(model: Learner, seconds: float, seed: int = 0) -> int:
    """The trot teaches `model` while walking the robot for `seconds` of simulated time; returns pairs."""
    dt, pairs = 1.0 / WALK_RATE_HZ, 0
    with legged_robot(seed) as robot:
        teacher, asks = TrotTeacher(walk_spaces()), asked_movements(seed)
        phase, per_ask = robot.observe(), round(ASK_EVERY_S * WALK_RATE_HZ)
        eased = Easing(np.zeros(2), EASE_S)
        for tick in range(round(seconds * WALK_RATE_HZ)):
            if tick % per_ask == 0:
                asked = next(asks)
            x = np.concatenate([eased.step(asked, dt), phase])
            y, _ = teacher(x)
            model.learn_one(x, y)
            robot.step(y, dt)
            phase = robot.observe()
            pairs += 1
    return pairs


def walk_alone(gait, forward: float, turn: float, seconds: float = 10.0, seed: int = 0) -> Walked:
    """`gait(x) -> 12 leg targets` walks the robot under one steady movement for `seconds`."""
    dt = 1.0 / WALK_RATE_HZ
    with legged_robot(seed) as robot:
        sim = robot.sim
        start, yaw, turned, lowest = sim.base_pose()[0], sim.base_yaw(), 0.0, 1.0
        for _ in range(round(seconds * WALK_RATE_HZ)):
            robot.step(gait(np.concatenate([[forward, turn], robot.observe()])), dt)
            now = sim.base_yaw()
            turned += (now - yaw + np.pi) % (2 * np.pi) - np.pi
            yaw, lowest = now, min(lowest, sim.upright())
        distance = float(np.hypot(*(sim.base_pose()[0] - start)[:2]))
    return Walked(distance, turned, lowest)


def learned_gait(model: Learner):
    return lambda x: model.predict_one(x).y


def taught_walk_model(seconds: float, seed: int = 0, learner: str = DEFAULT_LEARNER) -> Learner:
    spaces = walk_spaces()
    model = make_learner(learner, spaces.input.dims, spaces.output.dims, seed=seed)
    teach_walk(model, seconds, seed)
    return model


def joint_rms(model: Learner, samples: int = 2000, seed: int = 0) -> float:
    """The learned gait against the trot on the same inputs: movements and phases drawn at random."""
    teacher, rng = TrotTeacher(walk_spaces()), np.random.default_rng(seed + 1)
    low, high = np.asarray(MOVE_BOX.low), np.asarray(MOVE_BOX.high)
    errors = []
    for _ in range(samples):
        angle = rng.uniform(0, 2 * np.pi)
        x = np.concatenate([rng.uniform(low, high), [np.sin(angle), np.cos(angle)]])
        errors.append(model.predict_one(x).y - teacher(x)[0])
    return float(np.sqrt(np.mean(np.square(errors))))
