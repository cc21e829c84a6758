"""Teaching a Gymnasium task, judged closed-loop: the student's own actions choose its next inputs.

In one process, Algorithm 2's tick (services.experiments.loop) over the gym platform. Two protocols:

- **blocks**: the person switches the teacher on for a block of ticks, then the student drives alone
  for whole episodes on a judging platform of its own seeds; then more teaching (the teaching
  platform's episodes go on across blocks, as a person's robot would), and so on;
- **asked** (the paper's mixed initiative, as HG-DAgger and ThriftyDAgger measure it): after a first
  lesson the student drives, and the person switches the teacher on only when the robot asks
  (unsure, confidence under 0.25), and off once it has been sure for SURE_TICKS; judged every
  `judge_every` ticks of driving.

A score normalises the student's mean return between a random policy's (0) and the teacher's (1),
both measured on the same judging seeds. Time is counted in ticks at RATE per second, the rate a
person teaches at over the bus (the gym profile's): 20 s of teaching are 1000 pairs, whatever the
environment's own step.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from services.arbitration.strategies import TeacherFirst
from services.experiments.loop import tick
from services.platforms.gym import GymPlatform
from services.teachers import make_teacher

RATE = 50.0
UNSURE = 0.25
JUDGE_SEED = 10_000  # judging episodes are seeded apart from the teaching ones
# the person switches the teacher off once the student has been sure this long: half a second, a person's
# time to see the ears change and press a key (at 0.2 s one pendulum seed of five, answered in slivers,
# grew sure of a swing that caught the pole only sometimes, and stalled at 0.47 without asking again)
SURE_TICKS = 25

# each environment of the benchmark and the teacher written for it
TASKS = {"Pendulum-v1": "pendulum", "CartPole-v1": "cartpole", "MountainCarContinuous-v0": "mountain-car",
         "Acrobot-v1": "acrobot"}


@dataclass
class Episode:
    episode_return: float
    steps: int
    unsure: int  # ticks answered below UNSURE
    at_bound: int  # ticks with an output within 2 % of its bound


@dataclass
class Judgement:
    episodes: list[Episode] = field(default_factory=list)

    @property
    def mean_return(self) -> float:
        return float(np.mean([e.episode_return for e in self.episodes]))

    @property
    def unsure_share(self) -> float:
        return sum(e.unsure for e in self.episodes) / max(1, sum(e.steps for e in self.episodes))

    @property
    def at_bound_share(self) -> float:
        return sum(e.at_bound for e in self.episodes) / max(1, sum(e.steps for e in self.episodes))

    def runaways(self, random_return: float) -> int:
        """Episodes more than half unsure and below a random policy's mean return."""
        return sum(e.unsure > e.steps / 2 and e.episode_return < random_return for e in self.episodes)


def play(platform: GymPlatform, policy, episodes: int, seed: int) -> Judgement:
    """Run `policy(x) -> (y, confidence)` for whole episodes from `seed` on."""
    box = platform.spaces.output
    low, high = np.asarray(box.low), np.asarray(box.high)
    centre, half = (low + high) / 2, np.maximum((high - low) / 2, 1e-12)
    continuous = platform.spaces.extra.get("choice") != "largest"
    judged = Judgement()
    x = platform.reset(seed=seed)
    for _ in range(episodes):
        steps, unsure, at_bound = 0, 0, 0
        while True:
            y, confidence = policy(x)
            platform.step(y, 1.0 / RATE)
            outcome = platform.outcome()
            x = platform.observe()
            steps += 1
            unsure += confidence < UNSURE
            at_bound += continuous and bool(np.any(np.abs(box.clip(y) - centre) >= 0.98 * half))
            if outcome.done:
                break
        judged.episodes.append(Episode(outcome.episode_return, steps, unsure, at_bound))
    return judged


def random_policy(platform: GymPlatform, seed: int):
    rng = np.random.default_rng(seed)
    box = platform.spaces.output
    return lambda x: (rng.uniform(box.low, box.high), 1.0)


def student_policy(learner):
    """The student alone: its answer whatever its confidence (no teacher, no default controller)."""
    def act(x):
        p = learner.predict_one(x)
        return p.y, p.confidence
    return act


@dataclass
class Baseline:
    """The teacher's and a random policy's mean return on the judging episodes."""
    teacher: float
    random: float

    def score(self, mean_return: float) -> float:
        return (mean_return - self.random) / (self.teacher - self.random)


def baseline(env: str, episodes: int, teacher: str | None = None) -> Baseline:
    with GymPlatform(env, seed=0) as platform:
        taught = make_teacher(teacher or TASKS[env], platform.spaces)
        best = play(platform, taught, episodes, JUDGE_SEED).mean_return
        random = play(platform, random_policy(platform, 0), episodes, JUDGE_SEED).mean_return
    return Baseline(best, random)


def judge(env: str, learner, episodes: int) -> Judgement:
    with GymPlatform(env, seed=0) as platform:
        return play(platform, student_policy(learner), episodes, JUDGE_SEED)


class Lesson:
    """A teacher, a student and the platform it is taught on; every call goes on where the last stopped."""

    def __init__(self, env: str, learner, teacher: str | None = None, seed: int = 0, teacher_params=None):
        self.platform = GymPlatform(env, seed=seed)
        self.teacher = make_teacher(teacher or TASKS[env], self.platform.spaces, **(teacher_params or {}))
        self.name = f"teacher/{teacher or TASKS[env]}"
        self.learner, self.strategy = learner, TeacherFirst(UNSURE)
        self.x = self.platform.observe()
        self.ticks = self.taught = 0

    def step(self, teaching: bool) -> float:
        """One tick of Algorithm 2; returns the student's confidence before it learned."""
        teachers = [(self.name, self.teacher)] if teaching else []
        spaces = self.platform.spaces
        decision, _, confidence = tick(self.x, teachers, self.learner, self.strategy, index=self.ticks,
                                       output_space=spaces.output, choice=spaces.extra.get("choice") == "largest")
        self.platform.step(decision.y, 1.0 / RATE)
        self.platform.outcome()
        self.x = self.platform.observe()
        self.ticks += 1
        self.taught += teaching
        return confidence

    def teach(self, ticks: int) -> None:
        for _ in range(ticks):
            self.step(True)

    def close(self) -> None:
        self.platform.close()


def blocks(env: str, learner, seed: int, block_seconds, episodes: int, base: Baseline) -> list[dict]:
    """Teach up to each of `block_seconds` (cumulative), judging the student alone after each."""
    lesson, rows = Lesson(env, learner, seed=seed), []
    try:
        for seconds in block_seconds:
            lesson.teach(int(round(seconds * RATE)) - lesson.ticks)
            judged = judge(env, learner, episodes)
            rows.append({"taught_s": seconds, "score": base.score(judged.mean_return),
                         "unsure": judged.unsure_share, "at_bound": judged.at_bound_share,
                         "runaways": judged.runaways(base.random)})
    finally:
        lesson.close()
    return rows


def asked(env: str, learner, seed: int, first_seconds: float, judge_every: int, max_seconds: float, episodes: int,
          base: Baseline, goal: float = 0.9) -> dict:
    """Mixed initiative: a first lesson, then the teacher only when asked, until the score reaches `goal`
    (or `max_seconds` of driving). Returns the teaching seconds and requests at that point."""
    lesson = Lesson(env, learner, seed=seed)
    try:
        lesson.teach(int(round(first_seconds * RATE)))
        teaching, sure_for, requests, history = False, 0, 0, []
        while lesson.ticks < max_seconds * RATE:
            for _ in range(judge_every):
                confidence = lesson.step(teaching)
                if not teaching and confidence < UNSURE:
                    teaching, sure_for, requests = True, 0, requests + 1  # the robot asks; the person answers
                elif teaching:
                    sure_for = sure_for + 1 if confidence >= UNSURE else 0
                    teaching = sure_for < SURE_TICKS
            score = base.score(judge(env, learner, episodes).mean_return)
            history.append({"driven_s": lesson.ticks / RATE, "taught_s": lesson.taught / RATE, "requests": requests,
                            "score": score})
            if score >= goal:
                break
    finally:
        lesson.close()
    reached = history[-1]["score"] >= goal if history else False
    return {"reached": reached, "taught_s": history[-1]["taught_s"] if history else first_seconds,
            "requests": requests, "history": history}
