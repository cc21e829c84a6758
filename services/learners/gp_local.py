"""One Gaussian process over a bounded memory, that learns from its teaching which inputs matter and
says how sure it is of its answer (Rasmussen & Williams 2006; relevance as in their ch. 5): a leaf of
the wired learner, `gp` (gp.py), which splits a leaf where its halves are better fitted apart.

It remembers up to `memory` samples and answers with the exact posterior over them. A pair within a
thousandth of the data's spread of a remembered one is not remembered again (a robot held still gives
thousands of them) but counted: the sample weighs as many, up to gp_repeats.REPEATS_COUNTED, and each other answer at
its place takes one away. Past `memory`, the most redundant are thinned (gp_memory: where the memory is
densest, the older of two close samples), so every region taught keeps its examples and a newer lesson
outweighs an older one there.
One length scale per input and the outputs' amplitude and
noise are refitted by maximum a posteriori evidence (gp_evidence) after `first_fit` samples and then
each time half as many again, 8, 12, 18, 27, ... (never on fewer samples than inputs: those cannot tell
which inputs matter), then every `refit_every`, and early when the teaching surprises the fit or spreads
an input further than the fit saw: inputs that do not explain the teaching (distractors, readings
dragged along) grow long length scales and stop mattering. The teacher is assumed right (the paper's
premise): the noise a fit may call the teaching's is at most `noise_ceiling` of the taught span
(default: half of `near`), so inconsistency beyond that is structure to be learned, not averaged away.
Serving live (`serve_live`, the learner service) a fit runs in a process of its own and is applied when
done; teaching that went on meanwhile is fitted next, so when teaching stops the last fit has seen it
all. Far from what it was taught the posterior reverts to the taught mean, and an answer is held to the
taught range plus 10 % of its span, unless the evidence says the map is linear: a linear map extends
past the part of it that was shown (the mirroring task, from 15-30 samples), a curved one's trend is not
followed away from what was taught.

Confidence is the probability that the answer is within `near` of the taught span from the map the
teacher shows, under the posterior: erf(near * span / (sd * sqrt 2)) for the least sure output, sd the
map's posterior sd (what more teaching would make surer, not the teaching's own noise: asking where the
teacher is inconsistent teaches nothing), times a ramp over the first 2 n_in samples (a handful of samples
says little about how much the outputs vary) and, along inputs that never varied (whose relevance no fit
could learn), the input envelope's novelty discount (services.learners.novelty). Far from everything
taught the sd is the prior's, at least half the span, and the confidence erf(near * sqrt 2): under the
paper's 0.25 where the robot asks for `near` up to 0.16, above it beyond (0.31 at 0.2: then only novelty
makes the robot ask, as ball seeking wants; control tasks take 0.1, deploy/gym.toml).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.linalg import solve_triangular
from scipy.special import erf

from . import gp_kernels
from .base import FADE, Learner, Prediction, Predictions
from .gp_evidence import Hyper, first_hyper
from .gp_factored import Factored
from .gp_fitting import SURPRISE_REFIT_GAP, Refitting
from .gp_memory import densest_older
from .gp_repeats import Repeats
from .inputs import check_positive, check_range, kernel_ready
from .novelty import InputEnvelope

# the smooth part's share of the prior variance under which the evidence calls a map linear: fits
# of the mirroring map give 2e-5 to 5e-5, of random curved maps 0.06 to 0.98
LINEAR_ENOUGH = 1e-3
# served live, a full memory may take a sixteenth more while the fitter thins it (LocalGP._room)
LIVE_ROOM = 16


class LocalGP(Factored, Refitting, Repeats, Learner):
    def __init__(self, n_in: int, n_out: int, seed: int = 0, *, memory: int = 800, near: float = 0.04,
                 fit_points: int = 256, first_fit: int = 8, refit_every: int = 1024, noise_floor: float = 1e-5,
                 relevance_prior_sd: float = 2.0, max_iterations: int = 60, novelty_scale: float = 0.25,
                 noise_ceiling: float | None = None):
        super().__init__(n_in, n_out, seed)
        self.memory, self.near, self.fit_points, self.first_fit = memory, near, fit_points, first_fit
        self.refit_every, self.noise_floor, self.max_iterations = refit_every, noise_floor, max_iterations
        self.relevance_prior_sd, self.novelty_scale = relevance_prior_sd, novelty_scale
        self.noise_ceiling = noise_ceiling
        for name, least in (("memory", 8), ("fit_points", 2), ("first_fit", 1), ("refit_every", 1),
                            ("max_iterations", 1)):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < least:
                raise ValueError(f"hyper-parameter {name} must be an integer of at least {least}, got {value!r}")
        check_range("near", near, 1e-6, 1.0)
        check_range("noise_floor", noise_floor, 1e-12, 0.5)
        check_positive("relevance_prior_sd", relevance_prior_sd)
        check_positive("novelty_scale", novelty_scale, strictly=False)  # 0: off
        if noise_ceiling is not None:
            check_range("noise_ceiling", noise_ceiling, 1e-6, 1.0)
        self._m = 0
        self._xs, self._ys = np.zeros((0, n_in)), np.zeros((0, n_out))
        self._born = np.zeros(0, dtype=np.int64)  # when each remembered sample was last taught
        self._repeats = np.zeros(0)  # how many times each was taught (gp_repeats): its noise is the fit's / that
        self._source = np.zeros(0, dtype=np.int64)  # who taught each (gp.GP's numbering): its noise is its teacher's
        self._chol, self._beta = np.zeros((0, 0)), np.zeros((0, n_out))
        # served live, the answer's own (gp_kernels.predict_one): the factor in float32, its first _rows32 rows
        # as chol's, and alpha = chol^-T beta, current while _alpha_ok; made current after learning
        self._chol32, self._alpha = np.zeros((0, 0), dtype=np.float32), np.zeros((0, n_out))
        self._rows32, self._alpha_ok = 0, False
        self._y_count, self._y_mean, self._y_sum_sq = 0, np.zeros(n_out), np.zeros(n_out)
        self._envelope = InputEnvelope(n_in)
        self._next_fit = first_fit
        # a tree with room sets may_split; its fits then weigh a split (gp_split), at each doubling of what
        # the leaf learned (searched at every refit, the searches' load under a busy robot's other processes
        # left a keyboard-taught ball seeker reaching the ball 4 times in 10, not 9), and leave one found in
        # proposed_split
        self.may_split, self.proposed_split, self._split_check = False, None, 0
        self._factored = False  # chol and beta hold the memory's posterior
        # in a batch learned live (gp.GP.learn_many): the factor is rebuilt once at its end, not updated per
        # sample and per thinning (_stale meanwhile)
        self._deferring = self._stale = False
        self._surprise_gap = SURPRISE_REFIT_GAP  # samples a surprise must wait since the last fit
        self._background, self._pending = False, None  # serve_live: fits in another process
        self._searching = None  # serve_live: a search for a split under way in the splitter's process
        self._thins = 0  # thinnings so far: a factor built elsewhere over rows since moved is not used
        self._sd_cache = None  # (envelope count, _input_sd)
        self._use(first_hyper(n_in, n_out), rebuild=False)  # also sets the surprise and spread baselines

    @classmethod
    def _unit_test_params(cls) -> dict:
        return {"memory": 200, "fit_points": 96}

    learns_sources = True  # by number: the tree's (gp.GP) numbering of its teachers

    def _checked_source(self, source) -> int:
        if not isinstance(source, (int, np.integer)) or isinstance(source, bool) or not 0 <= source < 256:
            raise ValueError(f"a leaf's source is its tree's number for a teacher, 0 to 255, got {source!r}")
        return int(source)

    @property
    def size(self) -> int:
        """Samples remembered."""
        return self._m

    @property
    def relevance(self) -> np.ndarray:
        """1 / length scale per input, in the inputs' own units: near 0 for an input ignored."""
        return self._inv_ell.copy()

    # --- learning ---------------------------------------------------------------------------
    def _learn_one(self, x: np.ndarray, y: np.ndarray, source: int = 0) -> None:
        self._collect()
        self._envelope.learn(x[None, :])
        self._count_target(y)
        if not self._taught_again(x, y):
            self._remember(x, y, source)
        self._fit_when_due()
        if self._background and self._factored and not self._deferring:
            self._ready_to_answer()  # served live: here, off the next answer's path (offline: at the next answer)

    def _remember(self, x: np.ndarray, y: np.ndarray, source: int = 0) -> None:
        if self._m >= self._room():
            self._thin()
        self._reserve(self._m + 1)
        m = self._m
        self._xs[m], self._ys[m], self._born[m], self._repeats[m] = x, y, self._y_count, 1.0
        self._source[m] = source
        if self._factored and self._deferring:
            self._m, self._stale = m + 1, True  # no surprise weighed: the answer it would test is not built
            return
        if not self._factored:
            self._m = m + 1
            # while every target taught has been the same the posterior is that constant, exactly: the
            # factor is built once something varies (an output no teacher moves costs nothing)
            if np.any(self._taught.span > 0.0):
                self._rebuild()
                self._refit()
            return
        before = np.empty(self.n_out)
        unit_var = gp_kernels.append(self._xs, self._chol, self._beta, m, kernel_ready(x),
                                     kernel_ready(y - self._hyper.mu), self._inv_ell, self._hyper.centre,
                                     self._smooth, self._linear, self._row_ratio(m), before)
        self._m = m + 1
        self._factor_changed(m)
        self._weigh_surprise(y - self._hyper.mu - before, unit_var)
        if self._background and self._m >= self.memory:
            self._refit()  # full: the fitter thins it (at once, or with the fit under way's successor)

    def _input_sd(self) -> np.ndarray:
        """Each input's spread over everything learned (0 for an input that never varied); read-only, kept
        until the envelope learns again (learning asks twice a sample)."""
        count = self._envelope.count
        if self._sd_cache is None or self._sd_cache[0] != count:
            sd = np.empty(self.n_in)
            gp_kernels.input_sd(self._envelope.mean, self._envelope.scatter, count, sd)
            sd.flags.writeable = False
            self._sd_cache = (count, sd)
        return self._sd_cache[1]

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
        grown = min(self.memory + self.memory // LIVE_ROOM, max(needed, 2 * rows, 32))
        for name in ("_xs", "_ys", "_born", "_repeats", "_source", "_beta"):
            old = getattr(self, name)
            new = np.zeros((grown,) + old.shape[1:], dtype=old.dtype)
            new[:rows] = old
            setattr(self, name, new)
        chol = np.zeros((grown, grown))
        chol[:rows, :rows] = self._chol
        self._chol = chol

    def _room(self) -> int:
        """Samples remembered before a thinning here: `memory`; served live, a little more, taught while the fitter
        thins the memory (gp_factor.fit_and_build): this only once it falls behind."""
        aside = self._background and self._factored and not self._deferring
        return self.memory + (self.memory // LIVE_ROOM if aside else 0)

    def _thin(self) -> None:
        """Forget an eighth of the memory where it is densest: repeatedly, of the closest two samples
        left, the older (gp_memory.densest_older)."""
        m = self._m
        self._keep(np.flatnonzero(~densest_older(self._xs[:m] * self._inv_ell, self._born[:m], self._to_forget())))
        if self._factored and self._deferring:
            self._stale = True
        elif self._factored:
            self._rebuild()

    def _to_forget(self) -> int:
        """How many samples a thinning of the memory as it is forgets: down to what an eighth less than `memory`
        leaves, whether thinned here at `memory` or by the fitter past it."""
        return self._m - self.memory + max(1, self.memory // 8)

    def _keep(self, rows: np.ndarray) -> None:
        """The memory becomes these rows, in this order (ascending: the order taught); its factor is yet to be
        built."""
        for name in ("_xs", "_ys", "_born", "_repeats", "_source"):
            array = getattr(self, name)
            array[:len(rows)] = array[rows]
        self._m = len(rows)
        self._thins += 1
        self._factor_changed(0)

    def defer_factor(self, deferring: bool) -> None:
        """Served live, a batch (gp.GP.learn_many) keeps the factor stale until it ends, then rebuilds it
        once, instead of updating it per sample and rebuilding it at each thinning: the mirroring learner
        took a quarter hour's 11,891 pairs in 28 s, against 35-40 s one at a time."""
        self._deferring = deferring and self._background
        if not deferring and self._stale:
            self._rebuild()

    def remembered_inputs(self) -> np.ndarray:
        """A copy of the inputs remembered (m, n_in)."""
        return self._xs[:self._m].copy()

    def part(self, rows: np.ndarray, hyper: Hyper | None = None) -> LocalGP:
        """A GP of the same parameters that remembers these rows of the memory, as if taught only them in the
        order they were taught: its own spread, range and running statistics, this fit's hyper-parameters
        (`hyper`, or this fit's) until a fit of its own, started at once (gp.GP splits a leaf into two of these)."""
        order = rows[np.argsort(self._born[rows], kind="stable")]
        child = self.clone()
        child._background, child._deferring = self._background, self._deferring
        k = len(order)
        child._reserve(k)
        child._xs[:k], child._ys[:k], child._born[:k] = self._xs[order], self._ys[order], np.arange(k)
        child._repeats[:k], child._source[:k] = self._repeats[order], self._source[order]
        child._m = child._n_learned = k
        child._envelope.learn(child._xs[:k])
        child._note_shown(child._xs[:k], child._ys[:k])
        for y in child._ys[:k]:
            child._count_target(y)
        child._next_fit = k + max(k // 2, 1)
        child.may_split = self.may_split
        if np.any(child._taught.span > 0.0):
            child._use(hyper or self._hyper)
            child._refit()  # its own fit, and whether it too is two regions, even if no teaching follows
        return child

    # --- prediction -------------------------------------------------------------------------
    def predict_one(self, x):
        """One answer by the compiled path (gp_kernels.answer_one), as _predict_many and _sane give it."""
        self._collect()
        x = kernel_ready(x)
        if x.shape != (self.n_in,) or not np.isfinite(x).all():
            return super().predict_one(x)  # raises the contract's error
        if self._m == 0:
            return Prediction(np.zeros(self.n_out), 0.0, np.full(self.n_out, np.inf))
        offset = np.empty(self.n_out)
        if self._factored and self._background:  # served live: no float64 factor read (gp_kernels.predict_one)
            self._ready_to_answer()
            unit_var = gp_kernels.predict_one(self._xs, self._chol32, self._alpha, self._m, x, self._inv_ell,
                                              self._hyper.centre, self._smooth, self._linear, self._ratio, offset)
        elif self._factored:  # offline, every answer as ever to the last bit (see _rebuild)
            unit_var = gp_kernels.predict_exact(self._xs, self._chol, self._beta, self._m, x, self._inv_ell,
                                                self._hyper.centre, self._smooth, self._linear, self._ratio, offset)
        else:  # the one value taught so far
            offset[:], unit_var = self._taught.low - self._hyper.mu, 0.0
        y, sd, taught, envelope = np.empty(self.n_out), np.empty(self.n_out), self._taught, self._envelope
        confidence = gp_kernels.answer_one(offset, unit_var, self._hyper.mu, self._ratio, self._hyper.log_sf,
                                           self._y_sum_sq, self._y_count, taught.low, taught.high, taught.floor,
                                           taught.ceiling, self.near, self._smooth > LINEAR_ENOUGH, x, envelope.mean,
                                           envelope.scatter, envelope.count, self._hyper.varied, self.novelty_scale,
                                           min(1.0, self._n_learned / (2.0 * self.n_in)), y, sd)
        if not (np.isfinite(y).all() and math.isfinite(confidence)):
            return self._sane_one(y, confidence, sd, x)  # counts and replaces what is broken
        return Prediction(y, min(max(confidence, 0.0), 1.0), sd)

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
        span, amplitude2 = self._taught.span, self._amplitude2()[None, :]
        sd = np.sqrt(unit_var[:, None] * amplitude2)  # of the teacher's next answer: the interval
        map_sd = np.sqrt(np.maximum(unit_var - self._ratio, 0.0)[:, None] * amplitude2)  # of the map: confidence
        with np.errstate(divide="ignore", invalid="ignore"):
            near = self.near * span / math.sqrt(2.0)
            per_output = np.where(map_sd > 0.0, erf(near / map_sd), 1.0)
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

    def _fades(self) -> bool:
        return self._smooth > LINEAR_ENOUGH  # a linear map goes on past what was shown (mirroring)

    def fade_widths(self, span: np.ndarray) -> np.ndarray:
        """Per input, the width over which answers fade beyond what was shown (base.FADE): FADE of the
        given span, or the length scale where longer (an input the map ignores fades little), none where
        the fit never saw the input vary."""
        return np.where(self._hyper.varied, np.maximum(1.0 / self._inv_ell, FADE * span), np.inf)

    def _fade(self, xs: np.ndarray, y: np.ndarray) -> np.ndarray:
        return y  # a leaf's tree fades its answers, beyond what the whole was shown (gp.GP)

    # --- snapshots --------------------------------------------------------------------------
    def __getstate__(self) -> dict:
        # unused rows stay out of snapshots, and so does a fit under way in the fitter's process
        state = dict(self.__dict__, _pending=None, _searching=None, _background=False, proposed_split=None,
                     _sd_cache=None, _rows32=0, _alpha_ok=False)
        del state["_chol32"], state["_alpha"]  # the answer's, made again from chol and beta
        m = self._m
        for name in ("_xs", "_ys", "_born", "_repeats", "_source", "_beta"):
            state[name] = getattr(self, name)[:m].copy()
        state["_chol"] = self._chol[:m, :m].copy()
        return state

    def __setstate__(self, state: dict) -> None:
        super().__setstate__(state)
        if len(self._repeats) != len(self._xs):  # a snapshot from before repeats were counted: each taught once
            self._repeats = np.ones(len(self._xs))
        if len(self.__dict__.get("_source", ())) != len(self._xs):  # from before teachers were told apart: one
            self._source = np.zeros(len(self._xs), dtype=np.int64)
        self._source = np.clip(np.asarray(self._source), 0, 255).astype(np.int64)  # (a snapshot may come from the bus)
        self.__dict__.setdefault("_thins", 0)
        self.__dict__.pop("_answer_cache", None)  # (a snapshot from when an answer's constants were kept)
        self._chol32, self._alpha = np.zeros((0, 0), dtype=np.float32), np.zeros((0, self.n_out))  # made when served
        self._rows32, self._alpha_ok = 0, False

