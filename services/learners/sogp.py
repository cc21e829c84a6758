"""Sparse online Gaussian process (Csató & Opper, Neural Computation 14(3), 2002).

The posterior is kept in Csató's parametrisation over a set of basis vectors (BV):
mean(x) = k(x)' alpha, var(x) = k** + k(x)' C k(x). A sample whose kernel feature is
(nearly) spanned by the BVs updates alpha and C without growing the set; otherwise it
becomes a BV. Past `capacity` BVs, the one whose removal changes the posterior least
(score |alpha_i|^2 / (Q_ii + C_ii)) is projected out. Outputs share BVs and C.
Confidence is 1 - var(x)/k**: 0 where the prior is untouched, near 1 on well-seen data,
lowered beyond the inputs learned (novelty_scale, services.learners.novelty).
The O(capacity^2) numerics are compiled (sogp_kernels), imported on first use.
"""
from __future__ import annotations

import math

import numpy as np

from .base import Learner, Predictions
from .inputs import check_positive, kernel_ready
from .novelty import InputEnvelope
from .registry import register


class SOGP(Learner):
    def __init__(self, n_in: int, n_out: int, seed: int = 0, *, capacity: int = 200,
                 length_scale: float | None = None, signal_var: float = 1.0,
                 noise_var: float = 1e-3, tolerance: float = 1e-4, novelty_scale: float = 0.25):
        super().__init__(n_in, n_out, seed)
        self.capacity, self.length_scale = capacity, length_scale
        self.signal_var, self.noise_var, self.tolerance = signal_var, noise_var, tolerance
        self.novelty_scale = check_positive("novelty_scale", novelty_scale, strictly=False)  # 0: off
        if not isinstance(capacity, (int, np.integer)) or capacity < 1:
            raise ValueError(f"hyper-parameter capacity must be a positive integer, got {capacity!r}")
        # unit-scaled inputs: a width of sqrt(n_in) keeps smooth maps smooth in any dimension;
        # the novelty tolerance keeps the Gram matrix of the basis well conditioned (at 1e-6
        # long streams of a smooth kernel went to NaN)
        scale = math.sqrt(n_in) if length_scale is None else check_positive("length_scale", length_scale)
        self._params = np.array([check_positive("signal_var", signal_var), scale,
                                 check_positive("noise_var", noise_var),
                                 check_positive("tolerance", tolerance), float(capacity)])
        cap = capacity + 1  # one spare row: a new BV is added before the worst is removed
        self._bv = np.zeros((cap, self.n_in))
        self._alpha = np.zeros((cap, self.n_out))
        self._c = np.zeros((cap, cap))
        self._q = np.zeros((cap, cap))  # inverse Gram matrix of the BVs
        self._count = np.zeros(1, dtype=np.int64)
        self._envelope = InputEnvelope(self.n_in)

    @classmethod
    def _unit_test_params(cls) -> dict:
        return {"capacity": 40}

    @property
    def size(self) -> int:
        return int(self._count[0])

    def _learn_one(self, x: np.ndarray, y: np.ndarray) -> None:
        _kernels().learn(self._bv, self._alpha, self._c, self._q, self._count, self._params,
                         kernel_ready(x), kernel_ready(y))
        self._envelope.learn(x[None, :])

    def _predict_many(self, xs: np.ndarray) -> Predictions:
        kss, noise = self._params[0], self._params[2]
        mean, var = _kernels().predict(self._bv, self._alpha, self._c, self._count, self._params,
                                       kernel_ready(xs))
        confidence = np.clip(1.0 - var / kss, 0.0, 1.0) * self._envelope.beyond_span(xs, self.novelty_scale)
        interval = np.repeat(np.sqrt(var + noise)[:, None], self.n_out, axis=1)
        return Predictions(mean, confidence, interval)


def _kernels():
    from . import sogp_kernels  # first use compiles or loads from numba's cache

    return sogp_kernels


register("sogp", SOGP)
