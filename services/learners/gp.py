"""Gaussian process regression that learns from its teaching which inputs matter, and says how
near its answer is to the teacher's (Rasmussen & Williams 2006; relevance as in their ch. 5).

It remembers up to `memory` samples and answers with the exact posterior over them. Past that,
the most redundant are thinned (of two close samples the older goes), so every region taught
keeps its examples and a newer lesson outweighs an older one there. One length scale per input
and the outputs' amplitude and noise are refitted by maximum a posteriori evidence (gp_evidence)
after `first_fit` samples and then each time half as many again, 8, 12, 18, 27, ... (never on
fewer samples than inputs: those cannot tell which inputs matter), then every `refit_every`, and
early when the teaching surprises the fit or spreads an input further than the fit saw: inputs
that do not explain the teaching (distractors, readings dragged along) grow long length scales
and stop mattering. Serving live (`serve_live`, the learner service) a fit runs on a thread of
its own and is applied when done; teaching that went on meanwhile is fitted next, so when
teaching stops the last fit has seen it all. Far from what it was taught the posterior reverts
to the taught mean, and an answer is held to the taught range plus 10 % of its span, unless the
evidence says the map is linear: a linear map extends past the part of it that was shown (the
mirroring task, from 15-30 samples), a curved one's trend is not followed away from what was
taught.

Confidence is the probability that the answer is within `near` of the taught span from the
teacher's, under the posterior: erf(near * span / (sd * sqrt 2)) for the least sure output, times
a ramp over the first 2 n_in samples (a handful of samples says little about how much the outputs
vary) and, along inputs that never varied (whose relevance no fit could learn), the input
envelope's novelty discount (services.learners.novelty).
"""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from functools import partial

import numpy as np
from scipy.linalg import solve_triangular
from scipy.special import erf

from . import gp_kernels
from .base import Learner, Predictions, check_positive, check_range, kernel_ready
from .gp_evidence import Hyper, first_hyper, fit_memory, linear_share
from .novelty import InputEnvelope
from .registry import register

# refit early once the mean squared standardised error of the last taught ticks passes SURPRISED
# (typical errors of two standard deviations), at most every SURPRISE_REFIT_GAP samples, and each
# such refit doubles the wait for the next
SURPRISED, SURPRISE_REFIT_GAP = 4.0, 8
# and once an input's spread grows past SPREAD_GROWTH times what the last fit saw: the teaching now
# spans a direction the fit hardly knew (an input that never varied starts to: the orange ball)
SPREAD_GROWTH = 2.0
# the smooth part's share of the prior variance under which the evidence calls a map linear: fits
# of the mirroring map give 2e-5 to 5e-5, of random curved maps 0.06 to 0.98
LINEAR_ENOUGH = 1e-3



_FITTER: ThreadPoolExecutor | None = None


def _fitter() -> ThreadPoolExecutor:
    """One thread for every GP of the process that serves live: fits queue rather than crowd the cores."""
    global _FITTER
    if _FITTER is None:
        _FITTER = ThreadPoolExecutor(max_workers=1, thread_name_prefix="gp-fit")
    return _FITTER


class GP(Learner):
    def __init__(self, n_in: int, n_out: int, seed: int = 0, *, memory: int = 800, near: float = 0.04,
                 fit_points: int = 256, first_fit: int = 8, refit_every: int = 1024, noise_floor: float = 1e-5,
                 relevance_prior_sd: float = 2.0, max_iterations: int = 60, novelty_scale: float = 0.25):
        super().__init__(n_in, n_out, seed)
        self.memory, self.near, self.fit_points, self.first_fit = memory, near, fit_points, first_fit
        self.refit_every, self.noise_floor, self.max_iterations = refit_every, noise_floor, max_iterations
        self.relevance_prior_sd, self.novelty_scale = relevance_prior_sd, novelty_scale
        for name, least in (("memory", 8), ("fit_points", 2), ("first_fit", 1), ("refit_every", 1),
                            ("max_iterations", 1)):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < least:
                raise ValueError(f"hyper-parameter {name} must be an integer of at least {least}, got {value!r}")
        check_range("near", near, 1e-6, 1.0)
        check_range("noise_floor", noise_floor, 1e-12, 0.5)
        check_positive("relevance_prior_sd", relevance_prior_sd)
        check_positive("novelty_scale", novelty_scale, strictly=False)  # 0: off
        self._m = 0
        self._xs, self._ys = np.zeros((0, n_in)), np.zeros((0, n_out))
        self._born = np.zeros(0, dtype=np.int64)  # when each remembered sample was learned
        self._chol, self._beta = np.zeros((0, 0)), np.zeros((0, n_out))
        self._y_count, self._y_mean, self._y_sum_sq = 0, np.zeros(n_out), np.zeros(n_out)
        self._envelope = InputEnvelope(n_in)
        self._next_fit = first_fit
        self._factored = False  # chol and beta hold the memory's posterior
        self._surprise_gap = SURPRISE_REFIT_GAP  # samples a surprise must wait since the last fit
        self._background, self._pending = False, None  # serve_live: fits on another thread
        self._use(first_hyper(n_in, n_out), rebuild=False)  # also sets the surprise and spread baselines

    @classmethod
    def _unit_test_params(cls) -> dict:
        return {"memory": 200, "fit_points": 96}

    @property
    def size(self) -> int:
        """Samples remembered."""
        return self._m

    @property
    def relevance(self) -> np.ndarray:
        """1 / length scale per input, in the inputs' own units: near 0 for an input ignored."""
        return self._inv_ell.copy()

    # --- learning ---------------------------------------------------------------------------
    def _learn_one(self, x: np.ndarray, y: np.ndarray) -> None:
        self._collect()
        self._envelope.learn(x[None, :])
        self._count_target(y)
        # an exact repeat of a remembered pair adds nothing (epochs over one data set would otherwise
        # tell the evidence there is no noise)
        if not self._remembered(x, y):
            self._remember(x, y)
        if self._y_count >= self._next_fit and self._pending is None:  # n_learned lags inside learn_many
            self._next_fit += min(max(self._next_fit // 2, 1), self.refit_every)
            if self._factored:
                self._refit()
        elif self._factored and self._y_count - self._last_fit >= SURPRISE_REFIT_GAP:
            if np.any(self._input_sd() > SPREAD_GROWTH * self._fitted_sd):
                self._refit()  # the teaching spans an input further than the fit saw
            elif self._surprise > SURPRISED and self._y_count - self._last_fit >= self._surprise_gap:
                # the teaching contradicts the fit; if refitting does not end that (a mismatch no fit can
                # mend), the next try waits twice as long
                self._surprise_gap = min(2 * self._surprise_gap, self.refit_every)
                self._refit()

    def _remembered(self, x: np.ndarray, y: np.ndarray) -> bool:
        m = self._m
        return bool(np.any(np.all(self._xs[:m] == x, axis=1) & np.all(self._ys[:m] == y, axis=1)))

    def _remember(self, x: np.ndarray, y: np.ndarray) -> None:
        if self._m == self.memory:
            self._thin()
        self._reserve(self._m + 1)
        m = self._m
        self._xs[m], self._ys[m], self._born[m] = x, y, self._y_count
        self._m = m + 1
        if not self._factored:
            # while every target taught has been the same the posterior is that constant, exactly: the
            # factor is built once something varies (an output no teacher moves costs nothing)
            if np.any(self._taught.span > 0.0):
                self._rebuild()
                self._refit()
            return
        before = np.empty(self.n_out)
        unit_var = gp_kernels.append(self._xs, self._chol, self._beta, m, kernel_ready(x),
                                     kernel_ready(y - self._hyper.mu), self._inv_ell, self._hyper.centre,
                                     self._smooth, self._linear, self._ratio, before)
        self._weigh_surprise(y - self._hyper.mu - before, unit_var)

    def _weigh_surprise(self, error: np.ndarray, unit_var: float) -> None:
        """Every taught tick tests what the learner would have said: a running mean of the squared
        standardised error (over the least expected output), which a refit resets."""
        with np.errstate(divide="ignore", invalid="ignore"):
            z2 = np.where(error != 0.0, error * error / (unit_var * self._amplitude2()), 0.0)
        self._surprise += (min(float(z2.max()), 25.0) - self._surprise) / SURPRISE_REFIT_GAP

    def _input_sd(self) -> np.ndarray:
        """Each input's spread over everything learned (0 for an input that never varied)."""
        sd = np.sqrt(self._envelope.sum_sq / max(self._envelope.count, 1))
        return np.where(sd > 1e-12 * (1.0 + np.abs(self._envelope.mean)), sd, 0.0)

    def _count_target(self, y: np.ndarray) -> None:
        """Welford's running mean and variance of the taught outputs, and their range (learned here
        too, not only after this call returns: a refit in this call uses it)."""
        self._y_count += 1
        delta = y - self._y_mean
        self._y_mean += delta / self._y_count
        self._y_sum_sq += delta * (y - self._y_mean)
        self._taught.learn(y)

    def _reserve(self, needed: int) -> None:
        rows = self._xs.shape[0]
        if needed <= rows:
            return
        grown = min(self.memory, max(needed, 2 * rows, 32))
        for name in ("_xs", "_ys", "_born", "_beta"):
            old = getattr(self, name)
            new = np.zeros((grown,) + old.shape[1:], dtype=old.dtype)
            new[:rows] = old
            setattr(self, name, new)
        chol = np.zeros((grown, grown))
        chol[:rows, :rows] = self._chol
        self._chol = chol

    def _thin(self) -> None:
        """Forget an eighth of the memory where it is densest: of two close samples, the older."""
        z = self._xs[:self._m] * self._inv_ell
        sq = (z * z).sum(1)
        d2 = sq[:, None] + sq[None, :] - 2.0 * z @ z.T
        np.fill_diagonal(d2, np.inf)
        nearest = d2.argmin(1)
        dropped = np.zeros(self._m, dtype=bool)
        goal = max(1, self.memory // 8)
        for i in np.argsort(d2[np.arange(self._m), nearest], kind="stable"):
            j = nearest[i]
            if not (dropped[i] or dropped[j]):
                dropped[i if self._born[i] < self._born[j] else j] = True
                goal -= 1
                if goal == 0:
                    break
        keep = np.flatnonzero(~dropped)
        for name in ("_xs", "_ys", "_born"):
            array = getattr(self, name)
            array[:len(keep)] = array[keep]
        self._m = len(keep)
        if self._factored:
            self._rebuild()

    # --- hyper-parameters ---------------------------------------------------------------------
    def serve_live(self) -> None:
        """Fit hyper-parameters on another thread from now on (a fit takes up to seconds; the loop must
        not wait), applying each at the next call once done. Offline use stays synchronous and
        deterministic."""
        self._background = True

    def _refit(self) -> None:
        if self._pending is not None:
            return  # one fit at a time; whatever asked for this one will ask again
        if self._m <= self.n_in:
            return  # fewer samples than inputs cannot tell which inputs matter: the prior's scales stand
        job = partial(fit_memory, self._xs[:self._m].copy(), self._ys[:self._m].copy(), self._hyper,
                      self.fit_points, self.relevance_prior_sd, self.noise_floor, self.max_iterations)
        seen = (self._input_sd(), self._y_count)  # what the fit sees, for the refit triggers
        if self._background:
            self._pending = (_fitter().submit(job), seen)
        else:
            self._use(job(), seen)

    def _collect(self) -> None:
        """Apply a fit done on the fitter's thread (a failed one leaves the last fit in place). If
        teaching went on while it ran, fit again: when teaching stops, the last fit has seen it all."""
        if self._pending is not None and self._pending[0].done():
            (done, seen), self._pending = self._pending, None
            if done.exception() is None:
                self._use(done.result(), seen)
            if self._y_count > seen[1]:
                self._refit()

    def _use(self, hyper: Hyper, seen: tuple | None = None, rebuild: bool = True) -> None:
        """Adopt a fit: the kernel's working quantities, the factor, and the refit triggers' baselines:
        the spread and count the fit saw (learning that went on while it ran is yet to be fitted)."""
        self._hyper = hyper
        self._inv_ell = np.exp(-hyper.log_ell)
        self._linear = linear_share(hyper.logit_linear)
        self._smooth = 1.0 - self._linear
        self._ratio = max(math.exp(2.0 * (hyper.log_sn - hyper.log_sf)), self.noise_floor)
        self._fitted_sd, self._last_fit = seen if seen is not None else (self._input_sd(), self._y_count)
        self._surprise = 0.0
        if rebuild:
            self._rebuild()

    def _rebuild(self) -> None:
        """The Cholesky factor and beta over the memory, from scratch."""
        m = self._m
        gram = self._kernel(self._xs[:m], self._xs[:m])
        while True:
            try:
                chol = np.linalg.cholesky(gram + self._ratio * np.eye(m))
                break
            except np.linalg.LinAlgError:  # rounding on near-duplicates: more noise, never a crash
                self._ratio *= 10.0
        self._chol[:m, :m] = chol
        self._beta[:m] = solve_triangular(chol, self._ys[:m] - self._hyper.mu, lower=True)
        self._factored = True

    def _kernel(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        za, zb = (a - self._hyper.centre) * self._inv_ell, (b - self._hyper.centre) * self._inv_ell
        dot = za @ zb.T
        d2 = (za * za).sum(1)[:, None] + (zb * zb).sum(1)[None, :] - 2.0 * dot
        return self._smooth * np.exp(-0.5 * np.maximum(d2, 0.0)) + self._linear * dot

    # --- prediction -------------------------------------------------------------------------
    def predict_one(self, x):
        self._collect()
        if not self._factored:
            return super().predict_one(x)
        x = kernel_ready(x)
        if x.shape != (self.n_in,) or not np.isfinite(x).all():
            return super().predict_one(x)  # raises the contract's error
        offset = np.empty(self.n_out)
        unit_var = gp_kernels.predict_one(self._xs, self._chol, self._beta, self._m, x, self._inv_ell,
                                          self._hyper.centre, self._smooth, self._linear, self._ratio, offset)
        many = self._answer(x[None, :], offset[None, :], np.array([unit_var]))
        return self._sane_one(many.y[0], float(many.confidence[0]), many.interval[0])

    def _predict_many(self, xs: np.ndarray) -> Predictions:
        self._collect()
        n, m = xs.shape[0], self._m
        if m == 0:
            return Predictions(np.zeros((n, self.n_out)), np.zeros(n), np.full((n, self.n_out), np.inf))
        if not self._factored:  # the one value taught so far
            return self._answer(xs, np.tile(self._taught.low - self._hyper.mu, (n, 1)), np.zeros(n))
        v = solve_triangular(self._chol[:m, :m], self._kernel(xs, self._xs[:m]).T, lower=True)
        prior = self._smooth + self._linear * (((xs - self._hyper.centre) * self._inv_ell) ** 2).sum(1)
        unit_var = np.maximum(prior + self._ratio - (v * v).sum(0), self._ratio)
        return self._answer(xs, v.T @ self._beta[:m], unit_var)

    def _amplitude2(self) -> np.ndarray:
        """Per output, the prior variance of the map. Far from what it was taught the answer may be
        anywhere in the taught range: at least half the span squared, whatever spread the fit saw
        (teaching shows only part of a map)."""
        fitted = math.exp(2.0 * self._hyper.log_sf) * self._y_sum_sq / max(self._y_count, 1)
        return np.maximum(fitted, (self._taught.span / 2) ** 2)

    def _answer(self, xs: np.ndarray, offset: np.ndarray, unit_var: np.ndarray) -> Predictions:
        span = self._taught.span
        sd = np.sqrt(unit_var[:, None] * self._amplitude2()[None, :])
        with np.errstate(divide="ignore", invalid="ignore"):
            per_output = np.where(sd > 0.0, erf(self.near * span / (sd * math.sqrt(2.0))), 1.0)
        # an answer is held within the taught range plus a margin, unless the evidence says the map is
        # linear (the smooth part's share of the variance under LINEAR_ENOUGH): a linear map extends past
        # the part of it that was shown, and there the posterior mean is the likelier answer than any
        # held one; a curved one's trend is not followed away from what was taught
        y = self._hyper.mu + offset
        if self._smooth > LINEAR_ENOUGH:
            y = self._taught.bound(y)
        ramp = min(1.0, self._n_learned / (2.0 * self.n_in))
        # the posterior's variance sees novelty along the inputs it was fitted on; only along an input that
        # never varied (its relevance unknown: the orange ball before any lesson with it) the envelope must
        unknown = ~self._hyper.varied if self._hyper.varied.any() else None
        confidence = per_output.min(1) * self._envelope.beyond_inputs(xs, self.novelty_scale, unknown) * ramp
        return Predictions(y, confidence, sd)

    def _bound(self, y: np.ndarray) -> np.ndarray:
        return y  # _answer has held what it does not trust

    # --- snapshots --------------------------------------------------------------------------
    def __getstate__(self) -> dict:
        # unused rows stay out of snapshots, and so does a fit under way on the fitter's thread
        state = dict(self.__dict__, _pending=None, _background=False)
        m = self._m
        for name in ("_xs", "_ys", "_born", "_beta"):
            state[name] = getattr(self, name)[:m].copy()
        state["_chol"] = self._chol[:m, :m].copy()
        return state


register("gp", GP)
