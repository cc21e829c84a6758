"""A GP leaf's factor (gp_local.LocalGP): built over its memory, offline as ever (numpy and LAPACK, to the last bit
of every replay and benchmark), served live by the compiled kernel matrix (gp_factor.factor_live); and the served
answer's copies of it, a float32 factor and alpha = chol^-T beta, made current after each change, off the answer
path, so that an answer reads no float64 factor (gp_kernels.predict_one)."""
from __future__ import annotations

import numpy as np
from scipy.linalg import solve_triangular

from . import gp_kernels
from .gp_factor import Shape, factor_live


class Factored:
    """LocalGP's factor: `_chol` and `_beta` over the first `_m` rows, each row's noise its teacher's; `_chol32` and
    `_alpha`, the served answer's, current up to `_rows32` and while `_alpha_ok`."""

    def _rebuild(self) -> None:
        """The Cholesky factor and beta over the memory, from scratch: served live by the compiled kernel matrix
        (_factor_live), offline as ever, so that every replay and benchmark answers as before to the last bit (in
        the closed loop of ball seeking a last bit is a different episode: a rounding of 1e-12 in the factor
        turned 2 of 50 orange episodes of benchmarks/experiments.py, and a pink one back)."""
        m = self._m
        if self._background:
            chol = self._factor_live()
        else:
            gram = self._kernel(self._xs[:m], self._xs[:m])
            while True:
                try:
                    noise = self._noise(m)
                    ratio = self._ratio if noise is None else self._ratio * noise
                    chol = np.linalg.cholesky(gram + np.diag(ratio / self._repeats[:m]))
                    break
                except np.linalg.LinAlgError:  # rounding on near-duplicates: more noise, never a crash
                    self._ratio *= 10.0
        self._chol[:m, :m] = chol
        self._beta[:m] = solve_triangular(chol, self._ys[:m] - self._hyper.mu, lower=True)
        self._factored, self._stale = True, False
        self._factor_changed(0)

    def _factor_changed(self, row: int) -> None:
        """chol from `row` on, or beta, changed: the answer's float32 factor and alpha are to be brought up to date."""
        self._rows32, self._alpha_ok = min(self._rows32, row), False

    def _ready_to_answer(self) -> None:
        """The float32 factor's rows changed since, and alpha, made current (O(m^2)), as large as chol and beta."""
        m = self._m
        if self._chol32.shape != self._chol.shape:
            self._chol32, self._alpha = np.zeros(self._chol.shape, dtype=np.float32), np.zeros(self._beta.shape)
            self._rows32, self._alpha_ok = 0, False
        if self._rows32 < m:
            gp_kernels.copy32(self._chol, self._chol32, self._rows32, m)
            self._rows32 = m
        if not self._alpha_ok:
            gp_kernels.back_solve(self._chol, self._beta, m, self._alpha)
            self._alpha_ok = True

    def warm_served(self) -> None:
        """A factored leaf answers once as served live, and a copy of its factor is built, weighed again and solved
        as served live (gram, reweigh, resolve): their kernels compiled, the leaf unchanged but for the answer's
        copies."""
        if not self._factored:
            return
        self._ready_to_answer()
        m, hyper = self._m, self._hyper
        gp_kernels.predict_one(self._xs, self._chol32, self._alpha, m, self._xs[0].copy(), self._inv_ell, hyper.centre,
                               self._smooth, self._linear, self._ratio, np.empty(self.n_out))
        chol, beta = self._chol.copy(), self._beta.copy()
        gp_kernels.gram(self._xs, m, self._inv_ell, hyper.centre, self._smooth, self._linear, np.empty((m, m)))
        gp_kernels.reweigh(chol, m, m - 1, self._ratio)
        gp_kernels.resolve(chol, beta, self._ys[:m] - hyper.mu, m, m - 1)

    def _factor_live(self) -> np.ndarray:
        """The factor by the compiled kernel matrix (gp_factor.factor_live), its noise ratio raised where rounding
        needed it."""
        built = factor_live(self._xs, self._m, self._repeats, self._hyper.centre,
                            Shape(self._inv_ell, self._smooth, self._linear, self._ratio), self._noise(self._m))
        self._ratio = built.ratio
        return built.chol

    def _noise(self, m: int) -> np.ndarray | None:
        """Each of the first m rows' noise over the fit's, by who taught it (gp_evidence.Hyper.noise_by_source);
        None while the fit knows one teacher (each row's is the fit's)."""
        if self._hyper.source_log_sn is None:
            return None
        return self._hyper.noise_by_source(self._source[:m], self.noise_floor)

    def _row_ratio(self, row: int) -> float:
        """Row `row`'s noise over the amplitude, its teacher's."""
        if self._hyper.source_log_sn is None:
            return self._ratio
        return self._ratio * float(self._hyper.noise_by_source(self._source[row:row + 1], self.noise_floor)[0])

    def _kernel(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        za, zb = (a - self._hyper.centre) * self._inv_ell, (b - self._hyper.centre) * self._inv_ell
        dot = za @ zb.T
        d2 = (za * za).sum(1)[:, None] + (zb * zb).sum(1)[None, :] - 2.0 * dot
        return self._smooth * np.exp(-0.5 * np.maximum(d2, 0.0)) + self._linear * dot
