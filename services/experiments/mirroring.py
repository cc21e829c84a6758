"""Section V.A, mirroring: inputs the 18 joint readings, outputs the 18 joint targets; a handler
moves the tail and, as distractors, every motor but the head; the teacher maps the tail's pan and
tilt to the head's. Runs at 30 Hz of simulated time, as fast as the machine steps it.

The figure of merit is the student's RMS error on the head axes (teacher's answer minus the
student's, radians) over a held-out tail trajectory (another handler seed, distractors moving)
with the student alone in control.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from services.experiments.evaluate import figure5_error
from services.experiments.loop import Trace, tick
from services.experiments.user import ScriptedUser
from services.learners import DEFAULT_LEARNER, make_learner
from services.platforms.aibo.handler import MIRRORING_DISTRACTORS, Handler
from services.platforms.aibo.joints import JOINT_INDEX
from services.platforms.aibo.platform import AiboPlatform
from services.teachers.functions import MirrorTeacher

MIRROR_RATE_HZ = 30.0
HEAD_AXES = (JOINT_INDEX["head_tilt"], JOINT_INDEX["head_pan"])
ERROR_BOUND = 0.05  # rad, the bound
HELD_OUT_SEED_OFFSET = 10_000  # held-out tail trajectories never share a seed with teaching


@dataclass
class MirrorRun:
    """A mirroring world: platform, handler and student, with the clock the handler follows."""

    seed: int
    learner: object
    platform: AiboPlatform
    handler: Handler
    trace: Trace = field(default_factory=Trace)

    def run(self, seconds: float, teachers: dict, user: ScriptedUser | None = None, record: bool = True,
            rate: float = MIRROR_RATE_HZ) -> None:
        """`seconds` of Algorithm 2 at `rate`; the named teachers are on while `user` teaches (all the
        time when user is None, never when `teachers` is empty)."""
        sim, dt = self.platform.sim, 1.0 / rate
        for _ in range(int(round(seconds * rate))):
            now = sim.sim_time
            mask, q = self.handler.at(now)
            sim.set_handled(mask, q)
            x = self.platform.observe()
            on = user is None or user.teaching(now, self._unsure())
            active = list(teachers.items()) if on else []
            decision, y_hat, confidence = tick(x, active, self.learner, fallback=x, index=len(self.trace.t),
                                               output_space=self.platform.spaces.output)
            if record:
                self.trace.add(now, x, decision, y_hat, confidence)
            self.platform.step(decision.y, dt)

    def _unsure(self) -> bool:
        return bool(self.trace.mode) and self.trace.mode[-1] == "unsure"


def new_run(seed: int, learner_name: str = DEFAULT_LEARNER, handler_seed: int | None = None, masked: bool = False,
            **hyper_parameters) -> MirrorRun:
    """masked=True: the per-output learner over `learner_name`, as deploy/mirroring.toml wires it, so
    that a partial teacher's pairs train only its own outputs (False: the whole vector trains).
    learner_name may be "per-output" itself (base= and params= in hyper_parameters, as a profile says)."""
    platform = AiboPlatform(seed=seed, command="joints", camera=False)
    platform.reset()
    if learner_name == "per-output":
        learner_name, hyper_parameters = hyper_parameters["base"], dict(hyper_parameters.get("params") or {})
    if masked:
        learner = make_learner("per-output", 18, 18, seed=seed, base=learner_name, params=hyper_parameters)
    else:
        learner = make_learner(learner_name, 18, 18, seed=seed, **hyper_parameters)
    handler = Handler(seed=seed if handler_seed is None else handler_seed, distractors=MIRRORING_DISTRACTORS)
    return MirrorRun(seed, learner, platform, handler)


def held_out_error(learner, seed: int, seconds: float = 10.0, platform: AiboPlatform | None = None) -> float:
    """The student alone on a held-out tail trajectory: RMS over the head axes and all ticks of
    (full mirroring teacher - student). Does not train the student (no teacher, no training)."""
    own = platform is None
    platform = platform or AiboPlatform(seed=seed, command="joints", camera=False)
    try:
        platform.reset(seed + HELD_OUT_SEED_OFFSET)
        run = MirrorRun(seed, learner, platform, Handler(seed=seed + HELD_OUT_SEED_OFFSET,
                                                         distractors=MIRRORING_DISTRACTORS))
        run.run(seconds, teachers={})
        error = mirroring_error(run.trace, platform.spaces)
        return float(np.sqrt(np.mean(error ** 2)))  # the RMS over every tick and head axis
    finally:
        if own:
            platform.close()


def mirroring_error(trace: Trace, spaces) -> np.ndarray:
    """Figure 5 for mirroring: per tick, RMS over the head axes of (full mirroring teacher - student)."""
    arrays = trace.arrays()
    return figure5_error(MirrorTeacher(spaces, axes="both"), arrays["x"], arrays["student"], outputs=HEAD_AXES)[1]


@dataclass
class MirrorResult:
    teach_seconds: float | None   # teacher activation until the held-out error stays under the bound
    curve: list                   # (seconds taught, held-out RMS) at every check
    final_error: float            # held-out RMS after all teaching
    trace: Trace                  # the teaching world's run, for Figure 5


def teach_seconds_until(curve: list, bound: float = ERROR_BOUND) -> float | None:
    """The first check from which every later check is under `bound` (None if the last is not)."""
    answer = None
    for seconds, error in curve:
        if error >= bound:
            answer = None
        elif answer is None:
            answer = seconds
    return answer


def one_teacher(seed: int, learner_name: str = DEFAULT_LEARNER, max_teach: float = 12.0, check_every: float = 0.5,
                held_out_seconds: float = 10.0, alone_seconds: float = 10.0, masked: bool = True,
                **hyper_parameters) -> MirrorResult:
    """Paper V.A with one teacher: teach in slices of `check_every` seconds, checking the student on
    the held-out trajectory after each; then `alone_seconds` of the student alone (for Figure 5).
    masked=True (as wired): the per-output learner; the teacher teaches every output anyway."""
    run = new_run(seed, learner_name, masked=masked, **hyper_parameters)
    teacher = {"teacher/mirror": MirrorTeacher(run.platform.spaces, axes="both")}
    checker = AiboPlatform(seed=seed, command="joints", camera=False)
    curve = []
    try:
        for k in range(1, int(round(max_teach / check_every)) + 1):
            run.run(check_every, teacher)
            curve.append((k * check_every, held_out_error(run.learner, seed, held_out_seconds, checker)))
        run.run(alone_seconds, teachers={})
    finally:
        checker.close()
        run.platform.close()
    return MirrorResult(teach_seconds_until(curve), curve, curve[-1][1], run.trace)


def two_teachers(seed: int, learner_name: str = DEFAULT_LEARNER, seconds_each: float = 10.0,
                 held_out_seconds: float = 10.0,
                 alone_seconds: float = 10.0, masked: bool = False, **hyper_parameters) -> MirrorResult:
    """Paper V.A with two partial teachers in turn: pan for `seconds_each`, then tilt; the student
    must then mirror both axes. curve: held-out error after the pan teacher and after both.
    masked=True is the system's wiring (per-output learner); False trains the whole output vector."""
    run = new_run(seed, learner_name, masked=masked, **hyper_parameters)
    spaces = run.platform.spaces
    checker = AiboPlatform(seed=seed, command="joints", camera=False)
    try:
        run.run(seconds_each, {"teacher/pan": MirrorTeacher(spaces, axes="pan")})
        after_pan = held_out_error(run.learner, seed, held_out_seconds, checker)
        run.run(seconds_each, {"teacher/tilt": MirrorTeacher(spaces, axes="tilt")})
        final = held_out_error(run.learner, seed, held_out_seconds, checker)
        run.run(alone_seconds, teachers={})
    finally:
        checker.close()
        run.platform.close()
    curve = [(seconds_each, after_pan), (2 * seconds_each, final)]
    return MirrorResult(teach_seconds_until(curve), curve, final, run.trace)
