"""Teaching a task nobody tuned for, judged as the robot would be: a learner is taught a random task
(services.learners.unknown_tasks) on a stream at `rate` Hz, a partial teacher speaking for the taught
outputs only; after each checkpoint it answers, alone, the next `held_out` seconds of the same stream.

What is measured, per checkpoint: the RMS and largest error over the taught outputs, how far answers
went beyond the taught range plus 10 % of its span, how many answers the model gave as NaN or inf,
and the calibration: errors of the answers given with confidence above SURE, and of the ticks whose
worst taught output is off by more than WRONG, the share on which the learner asked (below UNSURE).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from services.learners import make_learner
from services.learners.base import TaughtRange
from services.learners.unknown_tasks import UnknownTask

SURE, UNSURE, WRONG = 0.75, 0.25, 0.2


@dataclass
class Checkpoint:
    seconds: float
    rms: float
    max_abs: float
    beyond: float  # largest excursion past the taught range + 10 % of its span (<= 0: never)
    broken: int  # answers the model gave as NaN or inf
    answers: int
    sure_errors: np.ndarray = field(repr=False)  # errors of the taught outputs on ticks answered sure
    sure_ticks: int = 0
    wrong: int = 0  # ticks whose worst taught output was off by more than WRONG
    asked_when_wrong: int = 0
    median_confidence: float = 0.0


def judge(task: UnknownTask, learner: str, params: dict, checkpoints=(10.0, 30.0, 60.0), held_out: float = 30.0,
          rate: float = 30.0, kind: str = "trajectory", seed: int = 0) -> list[Checkpoint]:
    """Teach `learner` (per-output over it, as the mirroring profile wires its learner) and judge it at
    each checkpoint (seconds of teaching) on the next `held_out` seconds."""
    xs = task.stream(max(checkpoints) + held_out, rate, kind, seed)
    ys = task.target(xs)
    mask, taught = task.mask(), list(task.taught)
    model = make_learner("per-output", task.n_in, task.n_out, seed=seed, base=learner, params=params)
    results, done = [], 0
    for seconds in checkpoints:
        end = int(round(seconds * rate))
        for i in range(done, end):
            model.learn_one(xs[i], ys[i], mask=mask)
        done = end
        rows = slice(end, end + int(round(held_out * rate)))
        broken_before = model.n_broken
        p = model.predict_many(xs[rows])
        results.append(score(seconds, p.y[:, taught], p.confidence, ys[rows][:, taught], ys[:end, taught],
                             model.n_broken - broken_before))
    return results


def score(seconds: float, answers: np.ndarray, confidence: np.ndarray, truth: np.ndarray, taught: np.ndarray,
          broken: int) -> Checkpoint:
    error = answers - truth
    worst = np.abs(error).max(axis=1)
    held = TaughtRange(taught.shape[1])
    held.learn(taught)
    beyond = float(np.max(np.maximum(answers - held.ceiling, held.floor - answers)))
    wrong = worst > WRONG
    sure = confidence > SURE
    return Checkpoint(seconds, float(np.sqrt(np.mean(error ** 2))), float(worst.max()), beyond, broken, len(answers),
                      error[sure].ravel(), int(sure.sum()), int(wrong.sum()),
                      int(np.sum(wrong & (confidence < UNSURE))),
                      float(np.median(confidence)))


def pooled(checkpoints: list[Checkpoint]) -> dict:
    """Calibration and safety over many judged checkpoints (every task, every checkpoint)."""
    sure = np.concatenate([c.sure_errors for c in checkpoints]) if checkpoints else np.zeros(0)
    wrong = sum(c.wrong for c in checkpoints)
    return {"confident_rms": float(np.sqrt(np.mean(sure ** 2))) if len(sure) else None,
            "confident_share": sum(c.sure_ticks for c in checkpoints) / max(1, sum(c.answers for c in checkpoints)),
            "asks_when_wrong": sum(c.asked_when_wrong for c in checkpoints) / wrong if wrong else None,
            "wrong_ticks": wrong,
            "max_abs_err": max(c.max_abs for c in checkpoints),
            "beyond_taught": max(c.beyond for c in checkpoints),
            "nan_share": sum(c.broken for c in checkpoints) / max(1, sum(c.answers for c in checkpoints))}
