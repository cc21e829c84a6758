"""Sparse online Gaussian process (Csató & Opper, Neural Computation 14(3), 2002).

The posterior is kept in Csató's parametrisation over a set of basis vectors (BV):
mean(x) = k(x)' alpha, var(x) = k** + k(x)' C k(x). A sample whose kernel feature is
(nearly) spanned by the BVs updates alpha and C without growing the set; otherwise it
becomes a BV. Past `capacity` BVs, the one whose removal changes the posterior least
(score |alpha_i|^2 / (Q_ii + C_ii)) is projected out. Outputs share BVs and C.
Confidence is 1 - var(x)/k**: 0 where the prior is untouched, near 1 on well-seen data.
"""
from __future__ import annotations

import math

import numpy as np

from .base import Learner, Predictions, check_positive


class SOGP(Learner):
    def __init__(self, n_in: int, n_out: int, seed: int = 0, *, capacity: int = 200,
                 length_scale: float | None = None, signal_var: float = 1.0,
                 noise_var: float = 1e-3, tolerance: float = 1e-6):
        super().__init__(n_in, n_out, seed)
        self.capacity, self.length_scale = capacity, length_scale
        self.signal_var, self.noise_var, self.tolerance = signal_var, noise_var, tolerance
        if not isinstance(capacity, (int, np.integer)) or capacity < 1:
            raise ValueError(f"hyper-parameter capacity must be a positive integer, got {capacity!r}")
        # unit-scaled inputs: a width of sqrt(n_in) keeps smooth maps smooth in any dimension
        self._scale = math.sqrt(n_in) if length_scale is None else check_positive("length_scale", length_scale)
        self._kss = check_positive("signal_var", signal_var)
        self._noise = check_positive("noise_var", noise_var)
        self._tol = check_positive("tolerance", tolerance)
        cap = capacity + 1  # one spare row: a new BV is added before the worst is removed
        self._bv = np.zeros((cap, self.n_in))
        self._alpha = np.zeros((cap, self.n_out))
        self._c = np.zeros((cap, cap))
        self._q = np.zeros((cap, cap))  # inverse Gram matrix of the BVs
        self._m = 0

    @classmethod
    def _unit_test_params(cls) -> dict:
        return {"capacity": 40}

    @property
    def size(self) -> int:
        return self._m

    def _kernel(self, xs: np.ndarray, bv: np.ndarray) -> np.ndarray:
        d2 = (xs * xs).sum(1)[:, None] - 2.0 * xs @ bv.T + (bv * bv).sum(1)[None, :]
        return self._kss * np.exp(-0.5 * np.maximum(d2, 0.0) / self._scale ** 2)

    def _learn_one(self, x: np.ndarray, y: np.ndarray) -> None:
        m = self._m
        k = self._kernel(x[None, :], self._bv[:m])[0]
        c, q, alpha = self._c[:m, :m], self._q[:m, :m], self._alpha[:m]
        ck = c @ k
        var = self._kss + k @ ck
        denom = self._noise + var
        dq = (y - k @ alpha) / denom  # first derivative of the log evidence, per output
        dr = -1.0 / denom
        e_hat = q @ k
        gamma = self._kss - k @ e_hat  # squared distance of x's feature from the BV span
        if m > 0 and gamma < self._tol * self._kss:
            s = ck + e_hat  # projected update: x is explained by the current BVs
            alpha += np.outer(s, dq)
            c += dr * np.outer(s, s)
            return
        s = np.append(ck, 1.0)
        e_full = np.append(e_hat, -1.0)
        self._bv[m] = x
        self._alpha[m] = 0.0
        self._c[m, : m + 1] = self._c[: m + 1, m] = 0.0
        self._q[m, : m + 1] = self._q[: m + 1, m] = 0.0
        self._m = m = m + 1
        self._alpha[:m] += np.outer(s, dq)
        self._c[:m, :m] += dr * np.outer(s, s)
        self._q[:m, :m] += np.outer(e_full, e_full) / max(gamma, 1e-12)
        if m > self.capacity:
            self._remove(self._least_useful())

    def _least_useful(self) -> int:
        m = self._m
        scores = (self._alpha[:m] ** 2).sum(1) / np.maximum(np.diag(self._q)[:m] + np.diag(self._c)[:m], 1e-12)
        return int(np.argmin(scores))

    def _remove(self, i: int) -> None:
        """Project BV i out of the posterior (Csató & Opper, eq. 3.19-3.21)."""
        last = self._m - 1
        self._swap(i, last)
        rest = slice(0, last)
        a_star = self._alpha[last].copy()
        c_star, q_star = self._c[last, last], self._q[last, last]
        qs, cs = self._q[rest, last].copy(), self._c[rest, last].copy()
        self._alpha[rest] -= np.outer(qs, a_star) / q_star
        self._c[rest, rest] += c_star * np.outer(qs, qs) / q_star ** 2 - (np.outer(qs, cs) + np.outer(cs, qs)) / q_star
        self._q[rest, rest] -= np.outer(qs, qs) / q_star
        self._m = last

    def _swap(self, i: int, j: int) -> None:
        if i == j:
            return
        for array in (self._bv, self._alpha):
            array[[i, j]] = array[[j, i]]
        for matrix in (self._c, self._q):
            matrix[[i, j]] = matrix[[j, i]]
            matrix[:, [i, j]] = matrix[:, [j, i]]

    def _predict_many(self, xs: np.ndarray) -> Predictions:
        m = self._m
        k = self._kernel(xs, self._bv[:m])
        mean = k @ self._alpha[:m]
        var = self._kss + np.einsum("ij,ij->i", k @ self._c[:m, :m], k)
        var = np.clip(var, 0.0, self._kss)
        confidence = np.clip(1.0 - var / self._kss, 0.0, 1.0)
        interval = np.repeat(np.sqrt(var + self._noise)[:, None], self.n_out, axis=1)
        return Predictions(mean, confidence, interval)
