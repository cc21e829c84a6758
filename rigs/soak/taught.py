"""What the day's teaching alone makes of the student: the profile's wired learner trained offline on every pair
the run recorded (in the order learned), judged on the inputs of the last span alone as the live student was
(the teacher's program on each input, the same outputs and scale).

The student is judged against the program, but a soak's teaching is not only the program's: the person at the
page teaches too (in ball seeking with a stick, as finely as it says, on what it saw a tick before; a person
pressing keys would teach whole turns where the program turns by degrees), and a student answers what it was
taught. The live student's last error beside this one tells what the day itself cost it (kills, swaps, restarts,
lost pairs), apart from what it was taught; and the same learner trained only on the program's teachers' pairs
(the person's left out), what the person's teaching cost it: whether more of the program's teaching ever made it
worse. And the person's own pairs judged as the student is: how far from the program the person taught."""
from __future__ import annotations

import numpy as np

from services.recording.runs import RecordedRun
from services.replay.replay import learn_pairs, learner_from_spec


def taught_reference(run: RecordedRun, spec: str, judge, inputs: list, sources: set[str] | None = None
                     ) -> tuple[float | None, int]:
    """(the mean error over `inputs` of `spec` trained on the recorded run's pairs, how many pairs); None when
    there is nothing to judge. With `sources`, only the pairs those taught (teacher/<name>), in the same order."""
    model = learner_from_spec(spec, run.spaces.input.dims, run.spaces.output.dims, 0)
    rows = slice(None) if sources is None else np.flatnonzero(np.isin(run.pair_sources, sorted(sources)))
    taught = learn_pairs(model, run, rows)
    errors = [judge(x, run.spaces.output.clip(model.predict_one(x).y)) for x in inputs]
    errors = [e for e in errors if e is not None]
    return (float(np.mean(errors)) if errors else None), taught


def teaching_error(run: RecordedRun, judge, sources: set[str]) -> tuple[float | None, int]:
    """(the mean error of what `sources` taught, judged as the student is: the program on each pair's input against
    the pair's output, how many pairs judged); only pairs teaching every output judged. None: no such pair."""
    covers = run.pair_mask[:, judge.outputs].all(axis=1)  # (pairs are rows: (0, n_out) when none)
    rows = np.flatnonzero(np.isin(run.pair_sources, sorted(sources)) & covers)
    errors = [judge(run.pair_x[i], run.pair_y[i]) for i in rows]
    errors = [e for e in errors if e is not None]
    return (float(np.mean(errors)) if errors else None), len(errors)
