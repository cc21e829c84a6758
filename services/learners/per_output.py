"""One single-output learner per output, so that a pair can teach some outputs and leave the rest.

A partial teacher (say, the head's pan only) gives a pair whose other outputs are the student's
own guesses; learning those would unlearn what another teacher taught (docs/results.md). With
`learn_one(x, y, mask)` only the outputs where mask is 1 learn. For LWPR, whose receptive fields
are per output anyway, this is the same model; for the others it is n_out models side by side.
"""
from __future__ import annotations

import numpy as np

from .base import Learner, Predictions, as_vector


class PerOutput(Learner):
    accepts_mask = True

    def __init__(self, n_in: int, n_out: int, seed: int = 0, base: str = "lwpr", params: dict | None = None):
        super().__init__(n_in, n_out, seed)
        from . import LEARNERS, make_learner  # the registry imports this module
        if base not in LEARNERS or base == "per-output":
            raise ValueError(f"base must be a registered single learner, got {base!r}")
        self.base, self.params = base, dict(params or {})
        self._parts = [make_learner(base, n_in, 1, seed=seed + i, **self.params) for i in range(n_out)]

    def learn_one(self, x, y, mask=None) -> None:
        x = as_vector(x, self.n_in, "inputs")
        y = as_vector(y, self.n_out, "outputs")
        taught = np.ones(self.n_out, dtype=bool) if mask is None else as_vector(mask, self.n_out, "mask values") != 0
        for i in np.flatnonzero(taught):
            self._parts[i].learn_one(x, y[i:i + 1])
        self._n_learned += 1

    def _learn_one(self, x: np.ndarray, y: np.ndarray) -> None:
        for i, part in enumerate(self._parts):
            part.learn_one(x, y[i:i + 1])

    def _predict_many(self, xs: np.ndarray) -> Predictions:
        answers = [part.predict_many(xs) for part in self._parts]
        y = np.hstack([a.y for a in answers])
        # the least supported output decides how sure the student is
        confidence = np.min(np.vstack([a.confidence for a in answers]), axis=0)
        return Predictions(y, confidence)

    @property
    def size(self) -> int:
        return int(sum(part.size for part in self._parts))

    @classmethod
    def _unit_test_params(cls) -> dict:
        return {"base": "knn", "params": {"max_points": 300}}
