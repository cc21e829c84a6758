"""The floor every comparison needs: k nearest neighbours over a bounded memory.

Remembers the last max_points samples (a ring buffer, so a long stream forgets its
oldest samples and memory stays bounded) and predicts the inverse-distance weighted
mean of the k nearest. Confidence is a Gaussian of the nearest neighbour's distance in
units of a width: 1 on a remembered input, falling to 0 far from all of them, and
lowered beyond the inputs learned (novelty_scale, services.learners.novelty). The width is
learned from how fast answers go wrong with distance on the stream itself
(services.learners.distance_calibration), unless length_scale fixes it.
"""
from __future__ import annotations

import math

import numpy as np

from .base import Learner, Predictions, TaughtRange
from .inputs import check_positive
from .distance_calibration import KEEP, RECENT, DistanceCalibration
from .novelty import InputEnvelope
from .registry import register

_CHUNK = 512  # rows per distance block in predict_many: bounds its temporary memory


class KNN(Learner):
    state_classes = (DistanceCalibration,)

    def __init__(self, n_in: int, n_out: int, seed: int = 0, *, k: int = 5,
                 max_points: int = 10000, length_scale: float | None = None, novelty_scale: float = 0.25):
        super().__init__(n_in, n_out, seed)
        self.k, self.max_points, self.length_scale = k, max_points, length_scale
        self.novelty_scale = check_positive("novelty_scale", novelty_scale, strictly=False)  # 0: off
        for name in ("k", "max_points"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"hyper-parameter {name} must be a positive integer, got {value!r}")
        # unit-scaled inputs: neighbours within ~sqrt(n_in)/2 count as familiar, until calibrated
        scale = 0.5 * math.sqrt(n_in) if length_scale is None else check_positive("length_scale", length_scale)
        self._scale = scale
        self._calibration = DistanceCalibration() if length_scale is None else None
        self._xs = np.zeros((0, self.n_in))  # grows by doubling up to max_points
        self._ys = np.zeros((0, self.n_out))
        self._norms = np.zeros(0)  # each stored row's squared length
        self._count = 0
        self._next = 0  # ring position once memory is full
        self._envelope = InputEnvelope(self.n_in)  # over every input learned, not only those remembered

    @classmethod
    def _unit_test_params(cls) -> dict:
        return {"max_points": 300}

    @property
    def size(self) -> int:
        return self._count

    def _learn_one(self, x: np.ndarray, y: np.ndarray) -> None:
        self._learn_many(x[None, :], y[None, :])

    def _learn_many(self, xs: np.ndarray, ys: np.ndarray) -> None:
        self._envelope.learn(xs)
        if self._calibration is None:
            self._store(xs, ys)
            return
        first_judged = max(0, xs.shape[0] - KEEP)  # only the newest KEEP judgements are kept anyway
        self._store(xs[:first_judged], ys[:first_judged])
        # each pair is judged against the span taught before it, in a batch as one by one
        taught = TaughtRange(self.n_out)
        taught.low, taught.high = self._taught.low, self._taught.high
        taught.learn(ys[:first_judged])
        for x, y in zip(xs[first_judged:], ys[first_judged:]):
            self._judge(x, y, taught.span)
            self._store(x[None, :], y[None, :])
            taught.learn(y)

    def _judge(self, x: np.ndarray, y: np.ndarray, span: np.ndarray) -> None:
        """Answer a new pair from the memory without its newest RECENT samples, and note how wrong."""
        count = self._count
        if count - RECENT < self.k:
            return
        d2 = squared_distances(x[None, :], self._xs[:count], self._norms[:count])
        newest = self._next if count == self.max_points else count  # one past the newest row of the ring
        d2[0, (newest - 1 - np.arange(RECENT)) % count] = np.inf
        answer, dist, _ = neighbours(d2, self._ys[:count], self.k)
        share = np.abs(answer[0] - y) / np.maximum(span, 1e-12)
        self._calibration.judge(float(share.max()), float(dist[0].min()))

    def _store(self, xs: np.ndarray, ys: np.ndarray) -> None:
        take = min(self.max_points - self._count, xs.shape[0])
        if take > 0:
            self._reserve(self._count + take)
            self._xs[self._count:self._count + take] = xs[:take]
            self._ys[self._count:self._count + take] = ys[:take]
            self._norms[self._count:self._count + take] = np.einsum("ij,ij->i", xs[:take], xs[:take])
            self._count += take
            xs, ys = xs[take:], ys[take:]
        for x, y in zip(xs, ys):  # memory full: overwrite the oldest
            self._xs[self._next] = x
            self._ys[self._next] = y
            self._norms[self._next] = np.einsum("ij,ij->i", x[None, :], x[None, :])[0]  # as loading sums it
            self._next = (self._next + 1) % self.max_points

    def _reserve(self, needed: int) -> None:
        if needed <= self._xs.shape[0]:
            return
        rows = min(self.max_points, max(needed, 2 * self._xs.shape[0], 64))
        for name in ("_xs", "_ys", "_norms"):
            old = getattr(self, name)
            grown = np.zeros((rows, *old.shape[1:]))
            grown[:self._count] = old[:self._count]
            setattr(self, name, grown)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)  # unused rows stay out of snapshots
        state["_xs"], state["_ys"] = self._xs[:self._count].copy(), self._ys[:self._count].copy()
        del state["_norms"]  # a cache of the rows' squared lengths: made again on loading
        return state

    def __setstate__(self, state: dict) -> None:
        super().__setstate__(state)
        xs = self._xs  # (a snapshot's arrays are checked by answering a probe, after loading)
        self._norms = np.einsum("ij,ij->i", xs, xs) if isinstance(xs, np.ndarray) and xs.ndim == 2 else np.zeros(0)

    def _predict_many(self, xs: np.ndarray) -> Predictions:
        n = xs.shape[0]
        if self.size == 0:
            return Predictions(np.zeros((n, self.n_out)), np.zeros(n), np.full((n, self.n_out), np.inf))
        chunks = [self._predict_chunk(xs[start:start + _CHUNK]) for start in range(0, n, _CHUNK)]
        ys, confidence, spread = (np.concatenate(part) for part in zip(*chunks))
        return Predictions(ys, confidence * self._envelope.beyond_span(xs, self.novelty_scale), spread)

    def _predict_chunk(self, xs: np.ndarray):
        count = self._count
        y, dist, spread = neighbours(squared_distances(xs, self._xs[:count], self._norms[:count]), self._ys[:count],
                                     self.k)
        width = self._scale if self._calibration is None else self._calibration.width(self._scale)
        confidence = np.exp(-0.5 * (dist.min(1) / width) ** 2)
        return y, confidence, spread


def squared_distances(xs: np.ndarray, stored_x: np.ndarray, stored_norms: np.ndarray) -> np.ndarray:
    """(rows of xs, stored rows) squared distances, from the stored rows' squared lengths (one BLAS call)."""
    d2 = np.einsum("ij,ij->i", xs, xs)[:, None] - 2.0 * xs @ stored_x.T + stored_norms[None, :]
    return np.maximum(d2, 0.0, out=d2)


def neighbours(d2: np.ndarray, stored_y: np.ndarray, k: int):
    """Per row of d2: the inverse-distance weighted mean of its k nearest, their distances, their spread."""
    k = min(k, d2.shape[1])
    if k < d2.shape[1]:
        nearest = np.argpartition(d2, k - 1, axis=1)[:, :k]
    else:
        nearest = np.tile(np.arange(k), (d2.shape[0], 1))
    dist = np.sqrt(np.take_along_axis(d2, nearest, axis=1))
    weights = 1.0 / (dist + 1e-9)
    weights /= weights.sum(1, keepdims=True)
    near_y = stored_y[nearest]  # (rows, k, n_out)
    y = np.einsum("rk,rko->ro", weights, near_y)
    spread = np.sqrt(np.einsum("rk,rko->ro", weights, (near_y - y[:, None, :]) ** 2))
    return y, dist, spread


register("knn", KNN)
