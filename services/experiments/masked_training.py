"""A proposal, measured here before it changes the system: partial teachers train only their outputs.

Today a partial teacher's decision sends the whole output vector to the learner: the outputs the
teacher speaks for, and the student's own prediction for the others. Taught pan, the student
also "learns" that head tilt ignores the tail; taught tilt next, the only input that explains
both phases is the head's own tilt reading (it follows the command), so the student learns to
hold the head wherever it is and the merge fails (docs/results.md, figure 2). Training only the
taught outputs merges the two teachers. The learners' API has no per-output mask yet, so this
student holds one single-output learner per output, which for LWPR (receptive fields per
output) is the same model.
"""
from __future__ import annotations

import numpy as np

from services.learners import Prediction, make_learner


class PerOutputStudent:
    """n_out single-output learners; `learn_one(x, y, mask)` trains only where mask is set."""

    accepts_mask = True

    def __init__(self, name: str, n_in: int, n_out: int, seed: int = 0, **hyper_parameters):
        self.n_in, self.n_out = n_in, n_out
        self._learners = [make_learner(name, n_in, 1, seed=seed + i, **hyper_parameters) for i in range(n_out)]

    def predict_one(self, x) -> Prediction:
        answers = [learner.predict_one(x) for learner in self._learners]
        # the least supported output decides, as LWPR's own confidence does
        return Prediction(np.array([a.y[0] for a in answers]), float(min(a.confidence for a in answers)))

    def learn_one(self, x, y, mask=None) -> None:
        y = np.asarray(y, dtype=np.float64)
        for i, learner in enumerate(self._learners):
            if mask is None or mask[i]:
                learner.learn_one(x, y[i:i + 1])


def taught_outputs(proposals) -> np.ndarray | None:
    """Union of the teachers' masks; None when any teacher speaks for every output."""
    masks = [p.mask for _, p in proposals]
    if not masks or any(m is None for m in masks):
        return None
    return np.any(np.asarray(masks, dtype=bool), axis=0)
