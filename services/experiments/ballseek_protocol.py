"""The ball-seeking protocol: teaching by a scripted user, student-only episodes, and the orange
ball before and after a short correction. Each phase draws its arenas and ball spots from its
own seeded stream, so the evaluation episodes are never the teaching ones.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from services.experiments.ballseek import BALLSEEK_RATE_HZ, FAR, NEAR, BallWorld, ball_in_view, ball_spot
from services.experiments.evaluate import asking_rate
from services.experiments.loop import Trace
from services.experiments.user import ScriptedUser
from services.learners import DEFAULT_LEARNER, make_learner

TEACHING_SCHEDULE = ((0.0, 30.0), (40.0, 60.0), (70.0, 80.0))  # 60 s of teaching over 80 s, as in Figure 5
TEACHING_EPISODE_SECONDS = 15.0  # the person puts the ball elsewhere after this, or once reached
ORANGE_FAR = 1.0  # orange episodes are 20 s, so the ball is put where the teacher reaches it in time
PHASES = {"teach": 1, "episodes": 2, "orange_before": 3, "correct": 4, "orange_after": 5, "pink_after": 6}


def phase_rng(seed: int, phase: str) -> np.random.Generator:
    return np.random.default_rng([seed, PHASES[phase]])


def arena_seed(rng: np.random.Generator) -> int:
    return int(rng.integers(1_000_000))


def teach(world: BallWorld, learner, teacher, user: ScriptedUser, seconds: float, trace: Trace, seed: int) -> None:
    """`seconds` of Algorithm 2 over fresh arenas with only the pink ball; the teacher is on when the
    user says. A new arena and ball spot each time the ball is reached or after 15 s."""
    rng, start = phase_rng(seed, "teach"), world.clock
    while world.clock - start < seconds - 1e-9:
        arena = arena_seed(rng)
        world.start(arena, {"pink": ball_spot(rng, arena=arena)})
        length = min(TEACHING_EPISODE_SECONDS, seconds - (world.clock - start))
        world.run(length, learner, teacher, user, trace, target="pink")


def episodes(world: BallWorld, learner, seed: int, phase: str, count: int, seconds: float, target: str,
             trace: Trace | None = None, teacher=None, far: float | None = None, in_view: bool = True) -> list:
    """`count` episodes of `seconds` with only the `target` ball, the student alone (or the teacher,
    if given: its own score on the same episodes). Returns the time each reached it, or None.
    in_view=False puts the ball anywhere in the ring, behind the clutter too."""
    rng = phase_rng(seed, phase)
    results = []
    for _ in range(count):
        arena = arena_seed(rng)
        world.start(arena, {target: ball_spot(rng, NEAR, far or FAR, arena=arena if in_view else None)})
        results.append(world.run(seconds, learner, teacher, None, trace, target=target))
    return results


def correct(world: BallWorld, learner, teacher, seconds: float, trace: Trace, seed: int) -> None:
    """A short correction with the orange ball in view: the person keeps putting it down in front of
    the robot (every 3 s) while the teacher, which ignores orange, drives."""
    rng = phase_rng(seed, "correct")

    due = [3.0]

    def put_orange_ahead(w: BallWorld, t: float) -> None:
        if t >= due[0]:
            due[0] += 3.0
            w.sim.place_ball("orange", ball_spot(rng, NEAR, ORANGE_FAR, bearing=(-0.4, 0.4), pose=w.pose(),
                                                        arena=w.arena))

    arena = arena_seed(rng)
    world.start(arena, {"orange": ball_spot(rng, NEAR, ORANGE_FAR, bearing=(-0.4, 0.4), arena=arena)})
    world.run(seconds, learner, teacher, None, trace, on_tick=put_orange_ahead)


def answer_requests(world: BallWorld, learner, teacher, count: int, seconds: float, trace: Trace, seed: int) -> None:
    """The correction left to the robot's initiative: `count` orange-only episodes in which the person
    switches the teacher on for 2 s whenever the robot asks (green ears), and at no other time."""
    rng, user = phase_rng(seed, "correct"), ScriptedUser(answer_probability=1.0, seed=seed)
    for _ in range(count):
        arena = arena_seed(rng)
        world.start(arena, {"orange": ball_spot(rng, NEAR, ORANGE_FAR, arena=arena)})
        world.run(seconds, learner, teacher, user, trace, target="orange")


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


def run_ballseek(seed: int, learner_name: str = DEFAULT_LEARNER, teach_seconds: float = 60.0, schedule=TEACHING_SCHEDULE,
                 answer_probability: float = 0.0, n_episodes: int = 20, episode_seconds: float = 30.0,
                 n_orange: int = 5, orange_seconds: float = 20.0, correction_seconds: float = 20.0, n_pink_after: int = 5,
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
    learner = make_learner(learner_name, world.spaces.input.dims, world.spaces.output.dims, seed=seed, **hyper_parameters)
    user = ScriptedUser(schedule=schedule, answer_probability=answer_probability, seed=seed)
    trace, phases = Trace(), {}

    def phase(name: str, run):
        start = world.clock
        result = run()
        phases[name] = (start, world.clock)
        return result
    try:
        phase("taught", lambda: teach(world, learner, teacher, user, schedule_end(schedule, teach_seconds), trace, seed))
        taught = float(np.sum(trace.teaching)) / world.rate_hz
        reach = phase("pink alone", lambda: episodes(world, learner, seed, "episodes", n_episodes, episode_seconds,
                                                     "pink", trace))
        before = phase("orange", lambda: episodes(world, learner, seed, "orange_before", n_orange, orange_seconds,
                                                  "orange", trace, far=ORANGE_FAR))
        if correction == "scheduled":
            phase("correction", lambda: correct(world, learner, teacher, correction_seconds, trace, seed))
        else:
            phase("correction", lambda: answer_requests(world, learner, teacher, n_orange, orange_seconds, trace, seed))
        after = phase("orange after", lambda: episodes(world, learner, seed, "orange_after", n_orange, orange_seconds,
                                                       "orange", trace, far=ORANGE_FAR))
        pink_after = phase("pink after", lambda: episodes(world, learner, seed, "pink_after", n_pink_after,
                                                          episode_seconds, "pink", trace))
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
        unused = make_learner("knn", world.spaces.input.dims, world.spaces.output.dims)  # never asked: the teacher is always on
        reach = episodes(world, unused, seed, phase, n_episodes, episode_seconds, "pink", teacher=teacher,
                         in_view=in_view)
    finally:
        world.close()
    return float(np.mean([r is not None for r in reach]))
