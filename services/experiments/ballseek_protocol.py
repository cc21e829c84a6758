"""The ball-seeking protocol: teaching by a scripted user, student-only episodes, and the orange
ball before and after a short correction. Each phase draws its arenas and ball spots from its
own seeded stream, so the evaluation episodes are never the teaching ones.

The phases are written once, against a `Stage`: `WorldStage` runs them in this process (the
benchmark), `services.demo.ballseek.LiveStage` over the bus with every box a process (the demo).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Protocol

import numpy as np

from services.experiments.ballseek import BALLSEEK_RATE_HZ, FAR, NEAR, BallWorld, ball_in_view, ball_spot
from services.experiments.evaluate import asking_rate
from services.experiments.loop import Trace
from services.experiments.user import ScriptedUser
from services.learners import DEFAULT_LEARNER, make_learner

TEACHING_SCHEDULE = ((0.0, 30.0), (40.0, 60.0), (70.0, 80.0))  # 60 s of teaching over 80 s, as in Figure 5
TEACHING_EPISODE_SECONDS = 15.0  # the person puts the ball elsewhere after this, or once reached
ORANGE_FAR = 1.0  # orange episodes are 20 s, so the ball is put where the teacher reaches it in time
CORRECTION_PUT_SECONDS = 3.0  # during the correction the person puts the orange ball down this often
PHASES = {"teach": 1, "episodes": 2, "orange_before": 3, "correct": 4, "orange_after": 5, "pink_after": 6}

Teaching = ScriptedUser | bool  # the teacher on when the user says, always, or never


class Stage(Protocol):
    clock: float  # simulated seconds since the protocol began

    def episode(self, arena: int, balls: dict, seconds: float, teaching: Teaching = False,
                target: str | None = None) -> float | None:
        """Rebuild the arena from its seed with `balls` (colour -> (x, y); the others hidden), then run
        `seconds` of Algorithm 2 with the teacher on as `teaching` says (a user is asked every tick
        with the time on `clock` and whether the robot is unsure). Stops when the nose reaches the
        `target` ball and returns the episode's time then; None if it never did."""


def phase_rng(seed: int, phase: str) -> np.random.Generator:
    return np.random.default_rng([seed, PHASES[phase]])


def arena_seed(rng: np.random.Generator) -> int:
    return int(rng.integers(1_000_000))


def teach(stage: Stage, user: Teaching, seconds: float, seed: int) -> None:
    """`seconds` over fresh arenas with only the pink ball; the teacher is on when the user says
    (True: throughout). A new arena and ball spot each time the ball is reached or after 15 s."""
    rng, start = phase_rng(seed, "teach"), stage.clock
    while stage.clock - start < seconds - 1e-9:
        arena = arena_seed(rng)
        balls = {"pink": ball_spot(rng, arena=arena)}
        stage.episode(arena, balls, min(TEACHING_EPISODE_SECONDS, seconds - (stage.clock - start)), user, "pink")


def episodes(stage: Stage, seed: int, phase: str, count: int, seconds: float, target: str,
             far: float | None = None, in_view: bool = True, teaching: Teaching = False, on_episode=None) -> list:
    """`count` episodes of `seconds` with only the `target` ball, the student alone (teaching=True:
    the teacher's own score on the same episodes). Returns the time each reached it, or None.
    in_view=False puts the ball anywhere in the ring, behind the clutter too. `on_episode(i, result)`
    hears of each as it ends."""
    rng = phase_rng(seed, phase)
    results = []
    for i in range(count):
        arena = arena_seed(rng)
        balls = {target: ball_spot(rng, NEAR, far or FAR, arena=arena if in_view else None)}
        results.append(stage.episode(arena, balls, seconds, teaching, target))
        if on_episode is not None:
            on_episode(i, results[-1])
    return results


def correct(stage: Stage, seconds: float, seed: int) -> None:
    """A short correction: the teacher, which ignores orange, drives while the person keeps putting
    the orange ball down in front of the robot in a fresh arena, every 3 s."""
    rng = phase_rng(seed, "correct")
    for _ in range(max(1, round(seconds / CORRECTION_PUT_SECONDS))):
        arena = arena_seed(rng)
        balls = {"orange": ball_spot(rng, NEAR, ORANGE_FAR, bearing=(-0.4, 0.4), arena=arena)}
        stage.episode(arena, balls, CORRECTION_PUT_SECONDS, True)


def answer_requests(stage: Stage, count: int, seconds: float, seed: int) -> None:
    """The correction left to the robot's initiative: `count` orange-only episodes in which the person
    switches the teacher on for 2 s whenever the robot asks (green ears), and at no other time."""
    rng, user = phase_rng(seed, "correct"), ScriptedUser(answer_probability=1.0, seed=seed)
    for _ in range(count):
        arena = arena_seed(rng)
        stage.episode(arena, {"orange": ball_spot(rng, NEAR, ORANGE_FAR, arena=arena)}, seconds, user, "orange")


@dataclass
class WorldStage:
    """The protocol in this process: Algorithm 2 ticked by hand on a BallWorld."""
    world: BallWorld
    learner: object
    teacher: object
    trace: Trace | None = None

    @property
    def clock(self) -> float:
        return self.world.clock

    def episode(self, arena: int, balls: dict, seconds: float, teaching: Teaching = False,
                target: str | None = None) -> float | None:
        self.world.start(arena, balls)
        teacher = None if teaching is False else self.teacher
        user = teaching if isinstance(teaching, ScriptedUser) else None
        return self.world.run(seconds, self.learner, teacher, user, self.trace, target)


CORRECTIONS = ("scheduled", "answers")


@dataclass
class BallSeekResult:
    teaching_seconds: float
    reach_times: list            # per student episode (pink): seconds to reach, or None
    orange_before: list          # per orange-only episode before correction: approached?
    orange_after: list
    pink_after: list             # per pink episode after the correction: seconds to reach, or None
    trace: Trace = field(repr=False)
    spaces: object = field(repr=False)
    teacher: object = field(repr=False)
    phases: dict = field(default_factory=dict)  # name -> (start, stop), seconds of the trace's clock

    @property
    def success(self) -> float:
        return float(np.mean([r is not None for r in self.reach_times]))

    @cached_property
    def _arrays(self) -> dict:
        return self.trace.arrays()  # the run is over: the trace no longer grows

    def _in_phase(self, phase: str) -> dict:
        """The trace's arrays cut to `phase` (no rows if it did not happen)."""
        arrays = self._arrays
        start, stop = self.phases.get(phase, (0.0, 0.0))
        rows = (arrays["t"] >= start) & (arrays["t"] < stop)
        return {name: values[rows] for name, values in arrays.items()}

    def asking(self, phase: str, colour: str) -> float | None:
        """Of the student's ticks in `phase` with the `colour` ball in view, the fraction in which
        it asked for teaching (paper Fig. 4d); None if there were none."""
        ticks = self._in_phase(phase)
        return asking_rate(ticks["mode"], ball_in_view(ticks["x"], self.spaces.extra["inputs"], colour))

    def taught_seconds(self, phase: str) -> float:
        """Seconds of teaching given in `phase` (0 if it did not happen)."""
        return float(np.sum(self._in_phase(phase)["teaching"])) / self.spaces.extra["rate_hz"]


def run_ballseek(seed: int, learner_name: str = DEFAULT_LEARNER, teach_seconds: float = 60.0,
                 schedule=TEACHING_SCHEDULE,
                 answer_probability: float = 0.0, n_episodes: int = 20, episode_seconds: float = 30.0,
                 n_orange: int = 5, orange_seconds: float = 20.0, correction_seconds: float = 20.0,
                 n_pink_after: int = 5,
                 rate_hz: float = BALLSEEK_RATE_HZ, inputs: str = "slots", correction: str = "scheduled",
                 **hyper_parameters) -> BallSeekResult:
    """The whole V.B protocol for one seed. Teaching lasts until the schedule's teaching time
    (`teach_seconds` of teacher activation at most) has been given. The orange correction is
    "scheduled" (`correction_seconds` with the ball put in front of the robot) or "answers" (as many
    orange episodes as before it, the person answering every request for teaching). Then
    `n_pink_after` pink episodes: the corrected student must still seek pink."""
    if correction not in CORRECTIONS:
        raise ValueError(f"correction must be one of {CORRECTIONS}, got {correction!r}")
    world = BallWorld(seed, rate_hz=rate_hz, inputs=inputs)
    teacher = world.make_teacher()
    learner = make_learner(learner_name, world.spaces.input.dims, world.spaces.output.dims, seed=seed,
                           **hyper_parameters)
    user = ScriptedUser(schedule=schedule, answer_probability=answer_probability, seed=seed)
    trace, phases = Trace(), {}
    stage = WorldStage(world, learner, teacher, trace)

    def phase(name: str, run):
        start = world.clock
        result = run()
        phases[name] = (start, world.clock)
        return result
    try:
        phase("taught", lambda: teach(stage, user, schedule_end(schedule, teach_seconds), seed))
        taught = float(np.sum(trace.teaching)) / world.rate_hz
        reach = phase("pink alone", lambda: episodes(stage, seed, "episodes", n_episodes, episode_seconds, "pink"))
        before = phase("orange", lambda: episodes(stage, seed, "orange_before", n_orange, orange_seconds, "orange",
                                                  far=ORANGE_FAR))
        if correction == "scheduled":
            phase("correction", lambda: correct(stage, correction_seconds, seed))
        else:
            phase("correction", lambda: answer_requests(stage, n_orange, orange_seconds, seed))
        after = phase("orange after", lambda: episodes(stage, seed, "orange_after", n_orange, orange_seconds, "orange",
                                                       far=ORANGE_FAR))
        pink_after = phase("pink after", lambda: episodes(stage, seed, "pink_after", n_pink_after, episode_seconds,
                                                          "pink"))
    finally:
        world.close()
    return BallSeekResult(taught, reach, [r is not None for r in before], [r is not None for r in after], pink_after,
                          trace, world.spaces, teacher, {k: v for k, v in phases.items() if v[1] > v[0]})


def schedule_end(schedule, teach_seconds: float) -> float:
    """The time at which the schedule has given `teach_seconds` of teaching (or its end)."""
    given = 0.0
    for start, stop in schedule:
        if given + (stop - start) >= teach_seconds:
            return start + teach_seconds - given
        given += stop - start
    return schedule[-1][1] if schedule else 0.0


def teacher_success(seed: int, n_episodes: int = 20, episode_seconds: float = 30.0,
                    rate_hz: float = BALLSEEK_RATE_HZ, inputs: str = "slots", in_view: bool = True,
                    phase: str = "episodes") -> float:
    """The teacher's own score on the student's pink episodes of `phase` ("episodes", or "pink_after"
    the correction; same seed, same arenas and spots): the baseline the student is measured
    against. in_view=False: on spots behind the clutter too."""
    world = BallWorld(seed, rate_hz=rate_hz, inputs=inputs)
    try:
        teacher = world.make_teacher()
        unused = make_learner("knn", world.spaces.input.dims,
                              world.spaces.output.dims)  # never asked: the teacher is always on
        reach = episodes(WorldStage(world, unused, teacher), seed, phase, n_episodes, episode_seconds, "pink",
                         in_view=in_view, teaching=True)
    finally:
        world.close()
    return float(np.mean([r is not None for r in reach]))
