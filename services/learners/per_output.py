"""One single-output learner per output, so that a pair can teach some outputs and leave the rest.

A partial teacher (say, the head's pan only) gives a pair whose other outputs are the student's
own guesses; learning those would unlearn what another teacher taught (docs/results.md). With
`learn_one(x, y, mask)` only the outputs where mask is 1 learn. For LWPR, whose receptive fields
are per output anyway, this is the same model; for the others it is n_out models side by side.
"""
from __future__ import annotations

import numpy as np

from .base import Learner, Prediction, Predictions, as_matrix, as_vector
from .registry import LEARNERS, make_learner, register


class PerOutput(Learner):
    accepts_mask = True

    def __init__(self, n_in: int, n_out: int, seed: int = 0, base: str = "lwpr", params: dict | None = None):
        super().__init__(n_in, n_out, seed)
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

    def learn_many(self, xs, ys) -> None:
        """Each part learns its output's column by its own batch path. As in learn_one, the taught ranges,
        the inputs shown and the taught mean are the parts' (they hold and fade their own answers); this
        one's stay unlearned, as a pair learned one at a time leaves them."""
        xs = as_matrix(xs, self.n_in, "inputs")
        ys = as_matrix(ys, self.n_out, "outputs", rows=xs.shape[0])
        for i, part in enumerate(self._parts):
            part.learn_many(xs, ys[:, i:i + 1])
        self._n_learned += xs.shape[0]

    def predict_one(self, x) -> Prediction:
        x = as_vector(x, self.n_in, "inputs")
        answers = [part.predict_one(x) for part in self._parts]  # each part's own fast path
        taught = [a.confidence for a, part in zip(answers, self._parts) if part.n_learned > 0]
        return Prediction(np.array([a.y[0] for a in answers]), min(taught) if taught else 0.0)

    def _predict_many(self, xs: np.ndarray) -> Predictions:
        answers = [part.predict_many(xs) for part in self._parts]
        y = np.hstack([a.y for a in answers])
        # the least supported taught output decides how sure the student is; an output no teacher
        # ever spoke for is nobody's lesson (a pan-only teacher would otherwise leave it unsure for ever)
        taught = [a.confidence for a, part in zip(answers, self._parts) if part.n_learned > 0]
        confidence = np.min(np.vstack(taught), axis=0) if taught else np.zeros(len(xs))
        return Predictions(y, confidence)

    def serve_live(self) -> None:
        for part in self._parts:
            part.serve_live()

    @property
    def upkeep_under_way(self) -> int:
        return sum(part.upkeep_under_way for part in self._parts)

    def _bound(self, y: np.ndarray) -> np.ndarray:
        return y  # each part holds its own answers

    def _fades(self) -> bool:
        return False  # and fades them beyond what it was shown

    @property
    def n_broken(self) -> int:
        return self._n_broken + sum(part.n_broken for part in self._parts)

    @property
    def size(self) -> int:
        return int(sum(part.size for part in self._parts))

    @classmethod
    def _unit_test_params(cls) -> dict:
        return {"base": "knn", "params": {"max_points": 300}}


register("per-output", PerOutput)
