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

from services.demo.live import LiveRun
from services.experiments.ballseek import BALLSEEK_RATE_HZ, FAR, NEAR, ball_in_view, ball_spot
from services.experiments.ballseek_protocol import (ORANGE_FAR, TEACHING_EPISODE_SECONDS, TEACHING_SCHEDULE,
                                                   arena_seed, phase_rng)
from services.experiments.evaluate import asking_rate, figure5_error, half_range, plot_error
from services.experiments.judges import REACH_RADIUS, nose_distance
from services.experiments.user import ScriptedUser
from services.experiments.wiring import wired_learner
from services.perception.blobs import BlobDetector
from services.perception.slots import BlobSlots
from services.platforms.aibo.platform import MOVE_BOX
from services.teachers.ballseek import ball_seek_teacher
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


def episode(run: LiveRun, arena: int, balls: dict, seconds: float, rate: float, target: str = "pink",
            stop_when_reached: bool = False) -> float | None:
    """One episode: a fresh arena, then `seconds` of ticks; returns when the nose first came within
    0.2 m of the target ball (seconds from the start), or None."""
    run.reset_arena(arena, balls)
    time.sleep(0.2)  # let the reset land before judging
    start_tick, first_state = run.tick(), len(run.recorded[run.robot.state])
    want = np.array(balls[target])
    reached_at = None
    while run.tick() < start_tick + seconds * rate:
        run.run_ticks(1)
        for state in run.states(first_state):
            ball = np.array(state.balls.get(target, [np.inf] * 3))
            if np.linalg.norm(ball[:2] - want) > 0.05:  # a state from before the reset
                continue
            if reached_at is None and nose_distance(state.nose, ball) < REACH_RADIUS:
                reached_at = (run.tick() - start_tick) / rate
        first_state = len(run.recorded[run.robot.state])
        if reached_at is not None and stop_when_reached:
            break
    return reached_at


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
                   rate: float = BALLSEEK_RATE_HZ, layout: str = "slots", learner_params: dict | None = None) -> LiveRun:
    """learner None: the learner and settings deploy/ballseek.toml wires."""
    if learner is None:
        learner, learner_params = wired_learner("ballseek")
    run_dir.mkdir(parents=True, exist_ok=True)
    profile = run_dir / "ballseek.toml"
    params = "".join(f', "--param", "{k}={v}"' for k, v in (learner_params or {}).items())
    profile.write_text(PROFILE.format(logs=run_dir / "logs", rate=rate, seed=seed, learner=learner,
                                      state=run_dir / "state", layout=layout, learner_params=params))
    run = LiveRun(profile, run_dir, endpoint)
    run.wait_ready()
    return run


def teach_phase(run: LiveRun, schedule, seed: int, rate: float, answer_probability: float = 0.0) -> int:
    """The scripted user teaches on `schedule` (sim seconds) over fresh arenas with only the pink
    ball, a new one every 15 s, and answers the robot's unsure requests (green ears) with
    `answer_probability`; returns how many ticks were taught."""
    user = ScriptedUser(schedule=schedule, answer_probability=answer_probability, seed=seed)
    rng = phase_rng(seed, "teach")
    t0, teaching, taught = run.tick(), False, 0
    end = schedule[-1][1] if schedule else 0.0
    while (run.tick() - t0) / rate < end:
        arena = arena_seed(rng)
        run.reset_arena(arena, {"pink": ball_spot(rng, arena=arena), "orange": None})
        episode_start = run.tick()
        while (run.tick() - episode_start) / rate < TEACHING_EPISODE_SECONDS and (run.tick() - t0) / rate < end:
            want = user.teaching((run.tick() - t0) / rate, run.mode() == "unsure")
            if want != teaching:
                run.teach(want)
                teaching = want
            run.run_ticks(1)
            taught += teaching
    run.teach(False)
    return taught


def ball_episodes(run: LiveRun, count: int, seconds: float, seed: int, phase: str, rate: float,
                  target: str = "pink", far: float = FAR, on_episode=None) -> list:
    """`count` student-only episodes with only the `target` ball: time to reach it, or None each."""
    rng, other = phase_rng(seed, phase), "orange" if target == "pink" else "pink"
    results = []
    for i in range(count):
        arena = arena_seed(rng)
        results.append(episode(run, arena, {target: ball_spot(rng, NEAR, far, arena=arena), other: None}, seconds,
                               rate, target=target, stop_when_reached=True))
        if on_episode:
            on_episode(i, results[-1])
    return results


def correct_orange(run: LiveRun, seconds: float, seed: int, rate: float) -> None:
    """A short correction: the teacher (which ignores orange) drives while the person keeps putting
    the orange ball down in front of the robot, every 3 s."""
    rng = phase_rng(seed, "correct")
    run.teach(True)
    for _ in range(int(round(seconds / 3.0))):
        arena = arena_seed(rng)
        spot = ball_spot(rng, NEAR, ORANGE_FAR, bearing=(-0.4, 0.4), arena=arena)
        run.reset_arena(arena, {"orange": spot, "pink": None})
        run.run_ticks(int(3.0 * rate))
    run.teach(False)


def run_ballseek_live(run_dir: Path, endpoint: str, learner: str | None = None, seed: int = 0, episodes: int = 6,
                      episode_seconds: float = 30.0, orange_episodes: int = 3, orange_seconds: float = 20.0,
                      correction_seconds: float = 20.0, schedule=TEACHING_SCHEDULE, rate: float = BALLSEEK_RATE_HZ,
                      layout: str = "slots", answer_probability: float = 0.0, log=print) -> dict:
    """Teach on `schedule`; `episodes` student-only pink episodes; then, unless `orange_episodes`
    is 0, that many orange-only episodes, a correction with orange in view, and as many again."""
    started = time.monotonic()

    def say(text: str) -> None:
        log(f"{time.monotonic() - started:5.1f} s  {text}")

    def report(ball: str):
        return lambda i, reached: say(f"episode {i + 1}: " + (f"reached the {ball} ball in {reached:.1f} s"
                                                               if reached is not None else f"did not reach the {ball} ball"))

    run = start_ballseek(run_dir, endpoint, learner, seed, rate, layout)
    summary = {"learner": learner or "{} {}".format(*wired_learner("ballseek")), "seed": seed, "layout": layout,
               "episodes": episodes}
    try:
        say(f"all services ready; teaching with the pink ball (schedule {schedule}, simulated seconds)")
        t0 = run.tick()
        summary["taught_s"] = teach_phase(run, schedule, seed, rate, answer_probability) / rate
        say(f"taught {summary['taught_s']:.0f} s; the student alone now")
        phases = {"taught": (t0, run.tick())}

        def phase(name: str, work):
            start = run.tick()
            result = work()
            phases[name] = (start, run.tick())
            return result
        reach = phase("student", lambda: ball_episodes(run, episodes, episode_seconds, seed, "episodes", rate,
                                                       on_episode=report("pink")))
        summary.update(successes=sum(r is not None for r in reach), reach_s=reach)
        if orange_episodes:
            say("the orange ball alone, never seen while taught: does the student chase it like the pink one?")
            before = phase("orange_before", lambda: ball_episodes(run, orange_episodes, orange_seconds, seed,
                                                                  "orange_before", rate, target="orange", far=ORANGE_FAR,
                                                                  on_episode=report("orange")))
            say(f"correction: {correction_seconds:.0f} s of teaching with the orange ball in front of the robot")
            phase("correction", lambda: correct_orange(run, correction_seconds, seed, rate))
            after = phase("orange_after", lambda: ball_episodes(run, orange_episodes, orange_seconds, seed,
                                                                "orange_after", rate, target="orange", far=ORANGE_FAR,
                                                                on_episode=report("orange")))
            summary.update(orange_episodes=orange_episodes, orange_before=sum(r is not None for r in before),
                           orange_after=sum(r is not None for r in after))
        summary.update(figure5(run, rate, run_dir, first_tick=t0, layout=layout, phases=phases),
                       figure5_png=str(run_dir / "figure5.png"))
    finally:
        code = run.close()
    summary.update(supervisor_exit=code, wall_s=round(time.monotonic() - started, 1))
    (run_dir / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary
