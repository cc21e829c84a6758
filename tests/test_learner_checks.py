"""The conformance checks themselves, against deliberately broken learners (the checker
must fail them, with the reason pinned)."""
import numpy as np
import pytest

from services.learners.base import Learner, Predictions
from services.learners.checks import (
    check_confidence_doubts_a_query_off_the_span, check_confidence_in_unit_interval,
    check_confidence_knows_what_it_knows, check_inputs_not_mutated, check_learn_many_matches_learn_one,
    check_memory_bounded, check_no_aliasing, check_no_nan_on_degenerate_streams, check_predict_before_learn,
    check_sane_on_robot_streams,
)


class MeanLearner(Learner):
    """A correct but simple learner: the running mean, confident near seen inputs."""

    def __init__(self, n_in, n_out, seed=0):
        super().__init__(n_in, n_out, seed)
        self._sum = np.zeros(n_out)
        self._seen = np.zeros((0, n_in))

    @property
    def size(self):
        return min(len(self._seen), 1)

    def _learn_one(self, x, y):
        self._sum += y
        self._seen = x[None, :].copy() if len(self._seen) == 0 else self._seen

    def _predict_many(self, xs):
        if self._n_learned == 0:
            return Predictions(np.zeros((len(xs), self.n_out)), np.zeros(len(xs)))
        mean = self._sum / self._n_learned
        near = np.exp(-np.abs(xs - self._seen[0]).max(1))
        return Predictions(np.tile(mean, (len(xs), 1)), near)


class Mutating(MeanLearner):
    def _learn_one(self, x, y):
        super()._learn_one(x, y)
        x *= 2.0


class Aliasing(MeanLearner):
    def _learn_one(self, x, y):
        super()._learn_one(x, y)
        self._last = y  # kept by reference

    def _predict_many(self, xs):
        p = super()._predict_many(xs)
        return p if self._n_learned == 0 else Predictions(np.tile(self._last, (len(xs), 1)), p.confidence)


class Overconfident(MeanLearner):
    def _predict_many(self, xs):
        return Predictions(super()._predict_many(xs).y, np.ones(len(xs)))


class OutOfRange(MeanLearner):
    """Breaks the contract where a learner with its own fast paths could: the base class would clip
    a confidence of 1.5 coming from _predict_many."""

    def predict_many(self, xs):
        return Predictions(super().predict_many(xs).y, np.full(len(xs), 1.5))


class Hoarding(MeanLearner):
    def _learn_one(self, x, y):
        super()._learn_one(x, y)
        self._seen = np.vstack([self._seen, x])


class ConfidentBeforeLearning(MeanLearner):
    def _predict_many(self, xs):
        return Predictions(np.zeros((len(xs), self.n_out)), np.full(len(xs), 0.5))


class Extrapolating(MeanLearner):
    """Follows the inputs linearly wherever they go (what LWPR's local fits did on collinear data),
    overriding the public verb as a learner with fast paths could."""

    def predict_many(self, xs):
        p = super().predict_many(xs)
        return Predictions(p.y + xs[:, :1], np.zeros(len(xs)))


class NaNModel(MeanLearner):
    def _predict_many(self, xs):
        p = super()._predict_many(xs)
        return Predictions(np.full_like(p.y, np.nan), p.confidence)


class SureOffTheSpan(MeanLearner):
    """Sure wherever an input is within its own range, whatever the others do."""

    def _predict_many(self, xs):
        return Predictions(super()._predict_many(xs).y, np.where(np.abs(xs).max(1) <= 1.0, 0.9, 0.0))


class OwnLearnOne(MeanLearner):
    """A learn_one of its own that leaves the base class's bookkeeping, beside the inherited learn_many
    that keeps it (per-output's, before it had a learn_many of its own)."""

    def learn_one(self, x, y):
        self._learn_one(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        self._n_learned += 1


class LaggingCount(MeanLearner):
    """Keeps a running mean by n_learned, which the base class's learn_many counts only after the batch."""

    def __init__(self, n_in, n_out, seed=0):
        super().__init__(n_in, n_out, seed)
        self._mean = np.zeros(n_out)

    def _learn_one(self, x, y):
        super()._learn_one(x, y)
        self._mean = self._mean + (y - self._mean) / (self._n_learned + 1)

    def _predict_many(self, xs):
        p = super()._predict_many(xs)
        return p if self._n_learned == 0 else Predictions(np.tile(self._mean, (len(xs), 1)), p.confidence)


class BatchKeepsTheLastRow(MeanLearner):
    """A batch path of its own that learns only each batch's last row."""

    def _learn_many(self, xs, ys):
        self._learn_one(xs[-1], ys[-1])


def factory(cls):
    return lambda seed=0: cls(3, 2, seed=seed)


@pytest.mark.parametrize("check,broken,reason", [
    (check_inputs_not_mutated, Mutating, "learner wrote into caller's arrays"),
    (check_no_aliasing, Aliasing, "model aliases inputs"),
    (check_confidence_knows_what_it_knows, Overconfident, "not below 0.25"),
    (check_confidence_in_unit_interval, OutOfRange, r"confidence must be finite and in \[0, 1\]"),
    (check_memory_bounded, Hoarding, "model kept growing on a stationary stream"),
    (check_predict_before_learn, ConfidentBeforeLearning, "an unlearned model predicts zeros, confidence 0"),
    (check_sane_on_robot_streams, Extrapolating, "beyond the taught range"),
    (check_sane_on_robot_streams, Overconfident, "confidence far from the teaching"),
    (check_no_nan_on_degenerate_streams, NaNModel, "answered NaN or inf"),
    (check_confidence_doubts_a_query_off_the_span, SureOffTheSpan, "two inputs apart 0.90, not below 0.25"),
    (check_learn_many_matches_learn_one, OwnLearnOne,
     r"1 rows learned, the last 1 by one learn_many: learn_many's taught range is \[.*\], learn_one's "
     r"\[inf, inf, -inf, -inf\]"),
    (check_learn_many_matches_learn_one, LaggingCount,
     "3 rows learned, the last 2 by one learn_many: learn_many's answers differ from learn_one's by up to"),
    (check_learn_many_matches_learn_one, BatchKeepsTheLastRow,
     "3 rows learned, the last 2 by one learn_many: learn_many's answers differ from learn_one's by up to"),
])
def test_check_fails_a_broken_learner(check, broken, reason):
    with pytest.raises(AssertionError, match=reason):
        check(factory(broken))


@pytest.mark.parametrize("check", [check_inputs_not_mutated, check_no_aliasing, check_memory_bounded,
                                   check_confidence_in_unit_interval, check_predict_before_learn,
                                   check_learn_many_matches_learn_one])
def test_check_passes_the_simple_learner(check):
    check(factory(MeanLearner))
