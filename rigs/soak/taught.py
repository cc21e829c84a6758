"""What the day's teaching alone makes of the student: the profile's wired learner trained offline on every pair
the run recorded (in the order learned), judged on the inputs of the last span alone as the live student was
(the teacher's program on each input, the same outputs and scale).

The student is judged against the program, but a soak's teaching is not only the program's: the person at the
page presses keys, whole turns and steps where the program turns by degrees, and a student taught them answers
them. The live student's last error beside this one tells what the day itself cost it (kills, swaps, restarts,
lost pairs), apart from what it was taught."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from services.recording.runs import load_run
from services.replay.replay import learn_all, learner_from_spec


def taught_reference(folder: Path, spec: str, judge, inputs: list) -> tuple[float | None, int]:
    """(the mean error over `inputs` of `spec` trained on the recording's pairs, how many pairs); None when
    there is nothing to judge."""
    run = load_run(folder)
    model = learner_from_spec(spec, run.spaces.input.dims, run.spaces.output.dims, 0)
    learn_all(model, run, len(run.pair_x))
    errors = [judge(x, run.spaces.output.clip(model.predict_one(x).y)) for x in inputs]
    errors = [e for e in errors if e is not None]
    return (float(np.mean(errors)) if errors else None), len(run.pair_x)
