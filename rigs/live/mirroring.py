"""Mirroring (paper V.A) as separate processes: the Aibo in lockstep at 30 Hz, a handler moving
its tail (and distractors), mirror teachers, a learner and the arbitrator under the supervisor."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from bus_schema.spaces import Spaces
from services.demo.live import LiveRun, when_ready
from services.experiments.wiring import wired_learner
from services.platforms.aibo.joints import HEAD_PAN, HEAD_TILT
from services.platforms.aibo.platform import JOINTS_BOX
from services.teachers.functions import MirrorTeacher

RATE = 30.0
PROFILE = """
[profile]
name = "live-mirroring"
log_dir = "{logs}"

[services.aibo]
box = "aibo"
args = ["--command", "joints", "--input", "joints", {pace}, "--camera-hz", "0", "--seed", "{seed}"]

[services.handler]
box = "handler"
args = ["--distractors", "mirroring", "--seed", "{seed}"]
{teachers}
[services.learner]
box = "learner"
args = ["--learner", "{learner}", "--seed", "{seed}"{learner_params}]

[services.arbitrator]
box = "arbitrator"
"""
TEACHER = """
[services.{name}]
box = "demonstrator"
args = ["--teacher", "{teacher}"{params}]
"""


def param_args(params: dict) -> str:
    """', "--param", "k=v"' per entry, values as the services read them (JSON, or a bare string)."""
    return "".join(f', "--param", "{k}={v if isinstance(v, str) else json.dumps(v)}"' for k, v in params.items())


def start_mirroring(run_dir: Path, endpoint: str, learner: str | None = None, seed: int = 0,
                    teachers: dict | None = None, learner_params: dict | None = None,
                    realtime: bool = False) -> LiveRun:
    """teachers: service name -> axes of a mirror teacher ('both', 'pan', 'tilt') or (teacher, params);
    default one teacher 'mirror' for both. learner None: the learner and settings deploy/mirroring.toml wires.
    In lockstep (the simulation's 30 Hz as fast as the loop answers) unless `realtime` (30 Hz of wall time, as
    deploy/mirroring.toml runs: a recording of what a user records)."""
    if learner is None:
        learner, learner_params = wired_learner("mirroring")
    teachers = teachers or {"mirror": "both"}
    run_dir.mkdir(parents=True, exist_ok=True)
    profile = run_dir / "mirroring.toml"
    specs = {n: ("mirror", {"axes": t}) if isinstance(t, str) else t for n, t in teachers.items()}
    blocks = "".join(TEACHER.format(name=n, teacher=t, params=param_args(p)) for n, (t, p) in specs.items())
    params = param_args(learner_params or {})
    pace = f'"--rate", "{RATE}"' if realtime else f'"--rate", "0", "--sim-hz", "{RATE}"'
    profile.write_text(PROFILE.format(logs=run_dir / "logs", pace=pace, seed=seed,
                                      learner=learner, teachers=blocks, learner_params=params))
    return when_ready(LiveRun(profile, run_dir, endpoint))


def student_error(run: LiveRun, since_tick: int, axes=("pan", "tilt"), teacher=None,
                  until_tick: int | None = None) -> tuple[float, int]:
    """RMS (rad) over the head axes of (teacher's answer - the command) for student ticks from
    `since_tick` (to `until_tick`); the teacher is the full mirroring one unless given."""
    teacher = teacher or MirrorTeacher(Spaces(JOINTS_BOX, JOINTS_BOX))
    inputs = {m.tick: m.x for m in run.inputs() if since_tick <= m.tick <= (until_tick or m.tick)}
    outputs = [{"tilt": HEAD_TILT, "pan": HEAD_PAN}[a] for a in axes]
    errors = [teacher(inputs[c.tick])[0][outputs] - c.y[outputs]
              for c in run.commands() if c.tick in inputs and c.mode != "teacher"]
    return (float(np.sqrt(np.mean(np.square(errors)))) if errors else float("inf")), len(errors)
