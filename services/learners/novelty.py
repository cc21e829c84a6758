"""Doubt about inputs beyond experience, for learners whose own confidence cannot see it.

A kernel's width is shared by every input, so a value never seen along one input that never
varied (an orange ball after teaching with pink alone) barely moves a GP's variance or a
neighbour's distance: the robot would drive on, sure of itself, where it should ask. Nor can one
width see a query off the span of the data: taught while two inputs moved as one (a reading dragged
along by another), a query where they part is new however close it lies to some sample.

The envelope keeps the mean and covariance of everything learned. `beyond_span` measures how far a
query lies beyond mean +- EXPERIENCED_SDS sd along each principal direction of that covariance (an
input that never varied, or two that never parted, span nothing along theirs); `beyond_inputs` the
same along chosen inputs' own axes. A query's confidence is multiplied by exp(-d^2 / (2 scale^2)).
LWPR does the axis-aligned form per receptive field (lwpr_placement.beyond_experience).
"""
from __future__ import annotations

import numba as nb
import numpy as np

# an input has been seen within this many standard deviations of its mean
EXPERIENCED_SDS = 3.0


@nb.njit(cache=True, nogil=True)  # no fast-math: numpy's numbers
def learn_row(x, mean, scatter, count):
    """One row into the mean and scatter of `count` rows (Chan's merge): scatter += delta delta' count / (count + 1),
    mean += delta / (count + 1), delta = x - mean."""
    total = count + 1
    weight = count / total
    delta = x - mean
    for i in range(x.shape[0]):
        for j in range(x.shape[0]):
            scatter[i, j] += delta[i] * delta[j] * weight
    for i in range(x.shape[0]):
        mean[i] += delta[i] / total


class InputEnvelope:
    """Running mean and covariance of the inputs learned (Chan's batch merge)."""

    def __init__(self, n_in: int):
        self.count = 0
        self.mean = np.zeros(n_in)
        self.scatter = np.zeros((n_in, n_in))  # sum of outer products of deviations from the mean
        self._axes = None  # (eigenvalues, eigenvectors) of the covariance, until the next learn

    def __getstate__(self) -> dict:
        return dict(self.__dict__, _axes=None)  # a cache: not part of what was learned

    def __setstate__(self, state: dict) -> None:
        if "scatter" not in state:  # a snapshot from when only each input's spread was kept
            state["scatter"] = np.diag(state.pop("sum_sq"))
        state.setdefault("_axes", None)
        self.__dict__.update(state)

    @property
    def sum_sq(self) -> np.ndarray:
        """Per input, the sum of squared deviations from the mean."""
        return np.diag(self.scatter).copy()

    def learn(self, xs: np.ndarray) -> None:
        n = xs.shape[0]
        if n == 0:
            return
        if n == 1:  # the batch merge for one row, without its zero scatter: the same numbers, compiled
            row = np.array(xs[0], dtype=np.float64)  # C-contiguous, writeable: the one signature compile_kernels built
            learn_row(row, self.mean, self.scatter, self.count)
            self.count += 1
            self._axes = None
            return
        batch_mean = xs.mean(axis=0)
        centred = xs - batch_mean
        total = self.count + n
        delta = batch_mean - self.mean
        self.scatter += centred.T @ centred + np.outer(delta, delta) * (self.count * n / total)
        self.mean += delta * n / total
        self.count = total
        self._axes = None

    def beyond_inputs(self, xs: np.ndarray, scale: float, inputs: np.ndarray | None = None) -> np.ndarray:
        """Per row of xs, the factor in (0, 1] for how far it lies beyond experience along the
        given inputs' axes (a mask; all inputs if None). 1 within experience, or scale 0 (off)."""
        if scale <= 0.0 or self.count == 0:
            return np.ones(xs.shape[0])
        sd = np.sqrt(np.maximum(np.diag(self.scatter), 0.0) / self.count)
        excess = np.maximum(np.abs(xs - self.mean) - EXPERIENCED_SDS * sd, 0.0)
        if inputs is not None:
            excess = excess[:, inputs]
        return np.exp(-0.5 * (excess * excess).sum(axis=1) / (scale * scale))

    def beyond_span(self, xs: np.ndarray, scale: float) -> np.ndarray:
        """As beyond_inputs, along the principal directions of the inputs learned."""
        if scale <= 0.0 or self.count == 0:
            return np.ones(xs.shape[0])
        if self._axes is None:
            variances, directions = np.linalg.eigh(self.scatter / self.count)
            self._axes = (np.sqrt(np.maximum(variances, 0.0)), directions)
        sd, directions = self._axes
        excess = np.maximum(np.abs((xs - self.mean) @ directions) - EXPERIENCED_SDS * sd, 0.0)
        return np.exp(-0.5 * (excess * excess).sum(axis=1) / (scale * scale))
