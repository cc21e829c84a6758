"""Ball seeking over a learned gait, in one process (the benchmark's protocol; deploy/hierarchy.toml
runs the same levels as processes). `LegsUnderMovement` is a robot that takes a movement, as the
Aibo in "move" mode does, but walks it with the walk level: every movement tick (15 Hz) runs four
walk ticks of Algorithm 2 at 60 Hz on the leg joints, the trot teaching while `teaching`, the
standing default controller when the student is unsure. A BallWorld over it is the seek level.
"""
from __future__ import annotations

import collections
from dataclasses import dataclass

import numpy as np

from bus_schema import Spaces
from services.chaining import Easing
from services.experiments import ballseek_protocol as protocol
from services.experiments.ballseek import BallWorld
from services.experiments.ballseek_protocol import WorldStage
from services.experiments.loop import tick
from services.experiments.walk import EASE_S, WALK_RATE_HZ, joint_rms, walk_spaces
from services.experiments.wiring import wired_learner
from services.learners import make_learner
from services.platforms.aibo.platform import MOVE_BOX, AiboPlatform
from services.teachers.trot import TrotTeacher

EPISODE_SECONDS = 20.0  # one episode with the ball, in process and live (rigs/live/hierarchy.py)


class LegsUnderMovement:
    """The Aibo walking movements with a learned (or, teaching, the hand-coded) gait: the Platform
    shape BallWorld drives (spaces, reset, step, hold, sim, close)."""

    def __init__(self, seed: int, walk_learner, teaching: bool = False):
        self.robot = AiboPlatform(seed=seed, command="legs", inputs="phase")
        self.walk = walk_spaces()
        self.spaces = Spaces(self.robot.spaces.input, MOVE_BOX, dict(self.robot.spaces.extra))
        self.learner, self.teaching = walk_learner, teaching
        self.trot, self.stand = TrotTeacher(self.walk), TrotTeacher(self.walk, stand=True)
        self.modes = collections.Counter()  # the walk level's decisions
        self.taught_ticks = 0
        self._eased = Easing(np.zeros(2), EASE_S)

    @property
    def sim(self):
        return self.robot.sim

    def reset(self, seed: int | None = None) -> np.ndarray:
        self._eased = Easing(np.zeros(2), EASE_S)
        return self.robot.reset(seed)

    def step(self, movement: np.ndarray, dt: float) -> np.ndarray:
        movement = self.spaces.output.clip(np.asarray(movement, dtype=np.float64))
        h = 1.0 / WALK_RATE_HZ
        for _ in range(max(1, round(dt * WALK_RATE_HZ))):
            x = np.concatenate([self._eased.step(movement, h), self.robot.observe()])
            teachers = [("teacher/trot", self.trot)] if self.teaching else []
            decision, _, _ = tick(x, teachers, self.learner, output_space=self.walk.output,
                                  default=("default/stand", self.stand))
            self.modes[decision.mode] += 1
            self.taught_ticks += decision.mode == "teacher"
            self.robot.step(decision.y, h)
        return movement

    def hold(self, dt: float) -> None:
        self.robot.hold(dt)

    def close(self) -> None:
        self.robot.close()


@dataclass
class TwoLevelResult:
    reach_times: list  # per episode: seconds to reach the pink ball, or None
    walk_teach_s: float  # simulated seconds the trot taught the walk level
    walk_joint_rms_rad: float  # learned against hand-coded leg targets on the same inputs
    walk_modes: dict  # the walk level's decisions in the episodes

    @property
    def success(self) -> float:
        return float(np.mean([r is not None for r in self.reach_times]))


def run_two_levels(seed: int, teach_s: float = 90.0, n_episodes: int = 10, chained: bool = True,
                   students: bool = True) -> TwoLevelResult:
    """chained: seeking over the walk level (else over the hand-coded gait: the flat robot). students:
    both levels taught for `teach_s` at once, then alone; else the hand-coded teachers drive the episodes."""
    seek_name, seek_params = wired_learner("hierarchy", "seek")
    walk_name, walk_params = wired_learner("hierarchy", "walk")
    legs = walk_learner = None
    if chained:
        spaces = walk_spaces()
        walk_learner = make_learner(walk_name, spaces.input.dims, spaces.output.dims, seed=seed, **walk_params)
        legs = LegsUnderMovement(seed, walk_learner, teaching=True)
    world = BallWorld(seed, platform=legs)  # no legs: the Aibo in "move" mode, the hand-coded gait
    seek_learner = make_learner(seek_name, world.spaces.input.dims, world.spaces.output.dims, seed=seed,
                                **seek_params)
    stage = WorldStage(world, seek_learner, world.make_teacher())
    try:
        if students:
            protocol.teach(stage, True, teach_s, seed)
        taught = legs.taught_ticks / WALK_RATE_HZ if legs is not None else 0.0
        if legs is not None:
            legs.teaching = not students
            legs.modes.clear()
        reach = protocol.episodes(stage, seed, "episodes", n_episodes, EPISODE_SECONDS, "pink",
                                  teaching=not students)
        rms = joint_rms(walk_learner, seed=seed) if (legs is not None and students) else float("nan")
        return TwoLevelResult(reach, taught, rms, dict(legs.modes) if legs is not None else {})
    finally:
        world.close()
