"""Ball seeking end to end as separate processes: the Aibo (lockstep, camera ticks), perception,
the ball-seeking teacher, a learner and the arbitrator under the supervisor; a scripted user
teaches on a schedule, then the student runs episodes alone, then meets the orange ball before
and after a short correction. Figure 5 and the data are saved.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from bus_schema import RobotState
from services.demo.live import LiveRun, decoded, when_ready
from services.experiments.ballseek import BALLS, BALLSEEK_RATE_HZ, ball_in_view
from services.experiments import ballseek_protocol as protocol
from services.experiments.ballseek_protocol import ORANGE_FAR, TEACHING_SCHEDULE, Teaching, schedule_end
from services.experiments.evaluate import asking_rate, figure5_error, half_range, plot_error
from services.experiments.judges import REACH_RADIUS, nose_distance
from services.experiments.user import ScriptedUser
from services.experiments.wiring import wired_learner
from services.perception.blobs import BlobDetector
from services.perception.slots import BlobSlots
from services.platforms.aibo.platform import MOVE_BOX
from services.teachers.ballseek import ball_seek_teacher
from services.waiting import poll
from bus_schema.spaces import Spaces

PROFILE = """
[profile]
name = "demo-ballseek"
log_dir = "{logs}"

[services.aibo]
box = "aibo"
args = ["--command", "move", "--input", "camera", "--rate", "0", "--sim-hz", "{rate}", "--seed", "{seed}"]

[services.perception]
box = "perception"
args = ["--layout", "{layout}"]

[services.seeker]
box = "demonstrator"
args = ["--teacher", "ballseek"]

[services.learner]
box = "learner"
args = ["--learner", "{learner}", "--seed", "{seed}", "--state-dir", "{state}"{learner_params}]
restart = "always"

[services.arbitrator]
box = "arbitrator"
"""


PHASE_LABELS = {"taught": "taught", "student": "pink alone", "orange_before": "orange",
                "correction": "correction", "orange_after": "orange after"}
PHASE_BALL = {"student": "pink", "orange_before": "orange", "orange_after": "orange"}  # the ball each puts down


class LiveStage:
    """The protocol's stage over the bus: the arena key rebuilds the arena, the teach key switches the
    teacher, and the robot's recorded states judge whether the nose reached the ball."""

    def __init__(self, run: LiveRun, rate: float):
        self.run, self.rate, self.first_tick = run, rate, run.tick()
        self.teaching, self.taught_ticks = False, 0

    @property
    def clock(self) -> float:
        return (self.run.tick() - self.first_tick) / self.rate

    def switch(self, on: bool) -> None:
        if on != self.teaching:
            self.run.teach(on)
            self.teaching = on

    def episode(self, arena: int, balls: dict, seconds: float, teaching: Teaching = False,
                target: str | None = None) -> float | None:
        first_state = len(self.run.recorded[self.run.robot.state])
        self.run.reset_arena(arena, {name: balls.get(name) for name in BALLS})
        first_state = self.landed(balls, first_state)
        start = self.run.tick()
        while self.run.tick() < start + seconds * self.rate:
            unsure = self.run.mode() == "unsure"
            self.switch(teaching.teaching(self.clock, unsure) if isinstance(teaching, ScriptedUser) else teaching)
            before = self.run.tick()
            self.run.run_ticks(1)
            self.taught_ticks += (self.run.tick() - before) * self.teaching
            if target is not None and self.reached(balls[target], target, first_state):
                return (self.run.tick() - start) / self.rate
            first_state = len(self.run.recorded[self.run.robot.state])
        return None

    def landed(self, balls: dict, since: int, timeout: float = 10.0) -> int:
        """Waits for the first state recorded from index `since` with every ball where it was put (the
        reset has landed); returns that state's index."""
        recorded, seen = self.run.recorded[self.run.robot.state], [since]

        def first_landed() -> int | None:
            for i in range(seen[0], len(recorded)):
                state = decoded(RobotState, *recorded[i][:2])
                if state is not None and all(at_spot(state, name, spot) for name, spot in balls.items()):
                    return i + 1  # (truthy: index + 1)
            seen[0] = len(recorded)
            return None
        found = poll(first_landed, timeout, 0.005)
        if found:
            return found - 1
        raise TimeoutError(f"the robot's state did not show the arena reset with {balls} within {timeout:g} s")

    def reached(self, spot, target: str, first_state: int) -> bool:
        """Whether a state recorded since `first_state`, after the reset, has the nose at the ball."""
        return any(at_spot(state, target, spot) and nose_distance(state.nose, state.balls[target]) < REACH_RADIUS
                   for state in self.run.states(first_state))  # (a ball standing elsewhere: before the reset)


def at_spot(state: RobotState, ball: str, spot) -> bool:
    """Whether `state` shows `ball` within 5 cm of where it was put."""
    return ball in state.balls and np.linalg.norm(np.array(state.balls[ball][:2]) - np.array(spot)) <= 0.05


def figure5(run: LiveRun, rate: float, out: Path, first_tick: int = 0, layout: str = "slots",
            phases: dict | None = None) -> dict:
    """Teacher run on every input the student saw; error against the student's answer over time.
    Returns the mean error while taught, and on the student's own ticks of each of `phases`
    (name -> (first tick, end tick)) as error_<name>; for phases with a ball, asks_<name>: the
    fraction of the student's ticks with that ball in view in which it asked to be taught."""
    inputs = {m.tick: m.x for m in run.inputs()}
    student = {p.tick: p.y for p in run.learner_proposals()}
    modes = {c.tick: c.mode for c in run.commands()}
    ticks = sorted(t for t in inputs if t in student and t in modes and t >= first_tick)
    x = np.array([inputs[t] for t in ticks])
    box = BlobSlots().box() if layout == "slots" else BlobDetector().box()
    teacher = ball_seek_teacher(Spaces(box, MOVE_BOX))
    student_y = np.array([student[t] for t in ticks])
    teacher_y, error = figure5_error(teacher, x, student_y, scale=half_range(MOVE_BOX))
    mode = np.array([modes[t] for t in ticks])
    teaching = mode == "teacher"
    t = (np.array(ticks, dtype=float) - first_tick) / rate
    np.savez(out / "run.npz", t=t, x=x, student_y=student_y, teacher_y=teacher_y, error=error, teaching=teaching,
             mode=mode)
    spans = {PHASE_LABELS.get(name, name): ((start - first_tick) / rate, (min(end, ticks[-1]) - first_tick) / rate)
             for name, (start, end) in (phases or {}).items()} if ticks else {}
    plot_error(out / "figure5.png", t, error, teaching, "Ball seeking: teacher vs student (Figure 5)",
               ylabel="RMS error / half range", smooth_window=5, phases=spans, asking=mode == "unsure")
    ticks = np.array(ticks)

    def mean(chosen):
        return float(np.mean(error[chosen])) if chosen.any() else None
    figures = {"ticks": len(ticks), "error_teaching": mean(teaching)}
    for name, (start, end) in (phases or {"student": (first_tick, np.inf)}).items():
        in_phase = (ticks >= start) & (ticks < end)
        figures[f"error_{name}"] = mean(~teaching & in_phase)
        if name in PHASE_BALL and len(ticks):
            figures[f"asks_{name}"] = asking_rate(mode[in_phase], ball_in_view(x[in_phase], layout, PHASE_BALL[name]))
    return figures


def start_ballseek(run_dir: Path, endpoint: str, learner: str | None = None, seed: int = 0,
                   rate: float = BALLSEEK_RATE_HZ, layout: str = "slots",
                   learner_params: dict | None = None) -> LiveRun:
    """learner None: the learner and settings deploy/ballseek.toml wires."""
    if learner is None:
        learner, learner_params = wired_learner("ballseek")
    run_dir.mkdir(parents=True, exist_ok=True)
    profile = run_dir / "ballseek.toml"
    params = "".join(f', "--param", "{k}={v}"' for k, v in (learner_params or {}).items())
    profile.write_text(PROFILE.format(logs=run_dir / "logs", rate=rate, seed=seed, learner=learner,
                                      state=run_dir / "state", layout=layout, learner_params=params))
    return when_ready(LiveRun(profile, run_dir, endpoint))


def run_ballseek_live(run_dir: Path, endpoint: str, learner: str | None = None, seed: int = 0, episodes: int = 6,
                      episode_seconds: float = 30.0, orange_episodes: int = 3, orange_seconds: float = 20.0,
                      correction_seconds: float = 20.0, schedule=TEACHING_SCHEDULE, teach_seconds: float = 60.0,
                      rate: float = BALLSEEK_RATE_HZ, layout: str = "slots", answer_probability: float = 0.0,
                      log=print) -> dict:
    """The protocol of services/experiments/ballseek_protocol.py over the bus: teach on `schedule`
    (until `teach_seconds` of it are given); `episodes` student-only pink episodes; then, unless
    `orange_episodes` is 0, that many orange-only episodes, a correction with orange in view, and as
    many again."""
    started = time.monotonic()

    def say(text: str) -> None:
        log(f"{time.monotonic() - started:5.1f} s  {text}")

    def report(ball: str):
        def said(i: int, reached: float | None) -> None:
            outcome = "not reached" if reached is None else f"reached in {reached:.1f} s"
            say(f"episode {i + 1}: the {ball} ball {outcome}")
        return said

    run = start_ballseek(run_dir, endpoint, learner, seed, rate, layout)
    summary = {"learner": learner or "{} {}".format(*wired_learner("ballseek")), "seed": seed, "layout": layout,
               "episodes": episodes}
    try:
        say(f"all services ready; teaching with the pink ball (schedule {schedule}, simulated seconds)")
        stage, phases = LiveStage(run, rate), {}

        def phase(name: str, work):  # each phase ends with the teacher off
            start = run.tick()
            result = work()
            stage.switch(False)
            phases[name] = (start, run.tick())
            return result
        user = ScriptedUser(schedule=schedule, answer_probability=answer_probability, seed=seed)
        phase("taught", lambda: protocol.teach(stage, user, schedule_end(schedule, teach_seconds), seed))
        summary["taught_s"] = stage.taught_ticks / rate
        say(f"taught {summary['taught_s']:.0f} s; the student alone now")
        reach = phase("student", lambda: protocol.episodes(stage, seed, "episodes", episodes, episode_seconds,
                                                           "pink", on_episode=report("pink")))
        summary.update(successes=sum(r is not None for r in reach), reach_s=reach)
        if orange_episodes:
            say("the orange ball alone, never seen while taught: does the student chase it like the pink one?")
            before = phase("orange_before", lambda: protocol.episodes(
                stage, seed, "orange_before", orange_episodes, orange_seconds, "orange", far=ORANGE_FAR,
                on_episode=report("orange")))
            say(f"correction: {correction_seconds:.0f} s of teaching with the orange ball in front of the robot")
            phase("correction", lambda: protocol.correct(stage, correction_seconds, seed))
            after = phase("orange_after", lambda: protocol.episodes(
                stage, seed, "orange_after", orange_episodes, orange_seconds, "orange", far=ORANGE_FAR,
                on_episode=report("orange")))
            summary.update(orange_episodes=orange_episodes, orange_before=sum(r is not None for r in before),
                           orange_after=sum(r is not None for r in after))
        summary.update(figure5(run, rate, run_dir, first_tick=phases["taught"][0], layout=layout, phases=phases),
                       figure5_png=str(run_dir / "figure5.png"))
    finally:
        code = run.close()
    summary.update(supervisor_exit=code, wall_s=round(time.monotonic() - started, 1))
    (run_dir / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary
