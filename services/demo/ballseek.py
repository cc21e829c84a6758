"""Ball seeking end to end as separate processes: the Aibo (lockstep, camera ticks), perception,
the ball-seeking teacher, a learner and the arbitrator under the supervisor; a scripted user
teaches on a schedule, then the student runs episodes alone. Figure 5 and the data are saved.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from services.demo.live import LiveRun
from services.experiments.ballseek import BALLSEEK_RATE_HZ, NEAR, ball_spot
from services.experiments.ballseek_protocol import TEACHING_EPISODE_SECONDS, TEACHING_SCHEDULE, arena_seed, phase_rng
from services.experiments.evaluate import error_over_time, plot_error, teacher_outputs
from services.experiments.judges import REACH_RADIUS, nose_distance
from services.experiments.user import ScriptedUser
from services.perception.blobs import BlobDetector
from services.platforms.aibo.platform import MOVE_BOX
from services.teachers.ballseek import BallSeekTeacher
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

[services.seeker]
box = "demonstrator"
args = ["--teacher", "ballseek"]

[services.learner]
box = "learner"
args = ["--learner", "{learner}", "--seed", "{seed}", "--state-dir", "{state}"]
restart = "always"

[services.arbitrator]
box = "arbitrator"
"""


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


def figure5(run: LiveRun, rate: float, out: Path, first_tick: int = 0) -> dict:
    """Teacher run on every input the student saw; error against the student's answer over time."""
    inputs = {m.tick: m.x for m in run.inputs()}
    student = {p.tick: p.y for p in run.learner_proposals()}
    modes = {c.tick: c.mode for c in run.commands()}
    ticks = sorted(t for t in inputs if t in student and t in modes and t >= first_tick)
    x = np.array([inputs[t] for t in ticks])
    spaces = Spaces(BlobDetector().box(), MOVE_BOX)
    teacher_y = teacher_outputs(BallSeekTeacher(spaces), x)
    student_y = np.array([student[t] for t in ticks])
    scale = (np.array(MOVE_BOX.high) - np.array(MOVE_BOX.low)) / 2
    error = error_over_time(teacher_y, student_y, scale=scale)
    teaching = np.array([modes[t] == "teacher" for t in ticks])
    t = (np.array(ticks, dtype=float) - first_tick) / rate
    np.savez(out / "run.npz", t=t, x=x, student_y=student_y, teacher_y=teacher_y, error=error, teaching=teaching)
    plot_error(out / "figure5.png", t, error, teaching, "Ball seeking: teacher vs student (Figure 5)",
               ylabel="RMS error / half range", smooth_window=5)
    on, off = error[teaching], error[~teaching]
    return {"ticks": len(ticks), "error_teaching": float(np.mean(on)) if len(on) else None,
            "error_student": float(np.mean(off)) if len(off) else None}


def run_ballseek_live(run_dir: Path, endpoint: str, learner: str = "lwpr", seed: int = 0, episodes: int = 6,
                      episode_seconds: float = 30.0, schedule=TEACHING_SCHEDULE, rate: float = BALLSEEK_RATE_HZ,
                      log=print) -> dict:
    profile = run_dir / "ballseek.toml"
    run_dir.mkdir(parents=True, exist_ok=True)
    profile.write_text(PROFILE.format(logs=run_dir / "logs", rate=rate, seed=seed, learner=learner,
                                      state=run_dir / "state"))
    started = time.monotonic()
    run = LiveRun(profile, run_dir, endpoint)
    try:
        run.wait_ready()
        log(f"{time.monotonic() - started:5.1f} s  all services ready; teaching (schedule {schedule})")
        user, rng = ScriptedUser(schedule=schedule, seed=seed), phase_rng(seed, "teach")
        t0, teaching, taught_ticks = run.tick(), False, 0
        end = schedule[-1][1] if schedule else 0.0
        while (run.tick() - t0) / rate < end:
            arena, balls = arena_seed(rng), {"pink": ball_spot(rng), "orange": None}
            run.reset_arena(arena, balls)
            episode_start = run.tick()
            while (run.tick() - episode_start) / rate < TEACHING_EPISODE_SECONDS and (run.tick() - t0) / rate < end:
                want = user.teaching((run.tick() - t0) / rate)
                if want != teaching:
                    run.teach(want)
                    teaching = want
                run.run_ticks(1)
                taught_ticks += teaching
        run.teach(False)
        log(f"{time.monotonic() - started:5.1f} s  taught {taught_ticks / rate:.0f} s; the student alone now")
        rng = phase_rng(seed, "episodes")
        reach = []
        for i in range(episodes):
            spot = ball_spot(rng, NEAR, 1.3)
            reach.append(episode(run, arena_seed(rng), {"pink": spot, "orange": None}, episode_seconds, rate,
                                 stop_when_reached=True))
            log(f"{time.monotonic() - started:5.1f} s  episode {i + 1}: "
                + (f"reached the pink ball in {reach[-1]:.1f} s" if reach[-1] is not None else "did not reach it"))
        errors = figure5(run, rate, run_dir, first_tick=t0)
        summary = {"learner": learner, "seed": seed, "taught_s": taught_ticks / rate,
                   "episodes": episodes, "successes": sum(r is not None for r in reach),
                   "reach_s": reach, **errors, "wall_s": round(time.monotonic() - started, 1),
                   "figure5": str(run_dir / "figure5.png")}
    finally:
        code = run.close()
    summary["supervisor_exit"] = code
    (run_dir / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary
