"""The wired learner: Gaussian processes over a partition of the input space, each leaf a GP that learns
its own relevance (gp_local): a treed GP, after Gramacy & Lee 2008.

What a teacher does is often different in different places. A pendulum's swing-up pumps energy by the
angle's cosine and rate, and its catch at the top turns on the angle's sine; one GP fitted to all of it
must choose one length scale per input for both, and once the swing's samples outnumbered the catch's,
its evidence ruled the sine irrelevant and called the catch noise (taught 8000 ticks, the student no
longer caught the pendulum: 0.43 where 4000 ticks had given 0.98). So a leaf's fits also weigh cutting
it in two (gp_split): where the halves' fits disagree on which inputs matter and explain the samples
better apart, the leaf splits, up to `leaves` leaves, and each half goes on with its own fit. A leaf
that is full forgets where its memory is densest (gp_memory). A map that is the same everywhere stays
one GP (the mirroring map, random smooth maps: benchmarks/unknown.py).

Each half also keeps, and goes on learning, the samples within a length scale across its cut (OVERLAP),
so answers near a cut see both sides. A query is answered by the leaf whose box holds it: its posterior,
its held range, its confidence; beyond everything shown it fades to the taught mean (base.FADE), by the
answering leaf's length scales. `memory` is each leaf's: an answer costs one leaf's O(memory^2).
"""
from __future__ import annotations

import copy

import numpy as np

from .base import Learner, Prediction, Predictions, TaughtRange, fade_toward, land_each
from .gp_local import LocalGP
from .registry import register

# each half of a cut also learns the samples within a length scale of the cut on the other side (at most
# OVERLAP of the leaf's samples' range along the cut input): cut apart, answers near the cut saw one side
# only, and random smooth maps taught for 60 s lost half their accuracy (benchmarks/unknown.py)
OVERLAP = 0.25
# teachers told apart, each with a noise of its own (gp_evidence.fit_rows); pairs of any more share the last's
MOST_SOURCES = 8


class GP(Learner):
    """Parameters: `leaves` (most leaves, 1: one GP), `memory` (samples per leaf), and every parameter of
    `gp_local.LocalGP`, passed to each leaf: `near` (the share of the taught span an answer must be
    within to count as right: confidence), `fit_points`, `first_fit`, `refit_every`, `noise_floor`,
    `relevance_prior_sd`, `max_iterations`, `novelty_scale`, `noise_ceiling` (the largest noise sd a fit
    may find, as a share of the taught span; default half of `near`).

    >>> import numpy as np
    >>> model = GP(2, 1)
    >>> for x in np.random.default_rng(0).uniform(-1, 1, (200, 2)):
    ...     model.learn_one(x, [np.sin(3 * x[0])])
    >>> p = model.predict_one([0.2, 0.0])
    >>> bool(abs(p.y[0] - np.sin(0.6)) < 0.05 and p.confidence > 0.5)
    True
    """

    state_classes = (LocalGP,)
    learns_sources = True

    def __init__(self, n_in: int, n_out: int, seed: int = 0, *, leaves: int = 8, memory: int = 800,
                 near: float = 0.04, fit_points: int = 256, first_fit: int = 8, refit_every: int = 1024,
                 noise_floor: float = 1e-5, relevance_prior_sd: float = 2.0, max_iterations: int = 60,
                 novelty_scale: float = 0.25, noise_ceiling: float | None = None):
        super().__init__(n_in, n_out, seed)
        if not isinstance(leaves, (int, np.integer)) or isinstance(leaves, bool) or not 1 <= leaves <= 256:
            raise ValueError(f"hyper-parameter leaves must be an integer from 1 to 256, got {leaves!r}")
        self.leaves, self.memory, self.near, self.fit_points = leaves, memory, near, fit_points
        self.first_fit, self.refit_every, self.noise_floor = first_fit, refit_every, noise_floor
        self.relevance_prior_sd, self.max_iterations, self.novelty_scale = relevance_prior_sd, max_iterations, \
            novelty_scale
        self.noise_ceiling = noise_ceiling
        root = LocalGP(n_in, n_out, seed, **self._leaf_params())  # also checks every leaf parameter
        root.may_split = leaves > 1
        self._parts = [root]
        self._low = np.full((1, n_in), -np.inf)  # leaf k holds the x with low[k] < x <= high[k]
        self._high = np.full((1, n_in), np.inf)
        self._reach_low, self._reach_high = self._low.copy(), self._high.copy()  # boxes widened by the overlaps
        self._sources: list[str] = []  # the teachers told apart, by number (pairs told no teacher: number 0's)

    def __setstate__(self, state: dict) -> None:
        sources = state.setdefault("_sources", [])  # a snapshot from before teachers were told apart: []
        if not isinstance(sources, list) or len(sources) > MOST_SOURCES or \
                not all(isinstance(name, str) for name in sources) or len(set(sources)) != len(sources):
            raise ValueError(f"a GP's teachers are at most {MOST_SOURCES} different names")
        super().__setstate__(state)

    def _leaf_params(self) -> dict:
        return {name: getattr(self, name) for name in LocalGP.param_names()}

    @classmethod
    def _unit_test_params(cls) -> dict:
        return {"memory": 100, "fit_points": 96, "leaves": 4}

    @property
    def size(self) -> int:
        """Samples remembered, over every leaf."""
        return int(sum(part.size for part in self._parts))

    @property
    def parts(self) -> list[LocalGP]:
        """The leaves, in no particular order (each with its box: `box(k)`)."""
        return list(self._parts)

    def box(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Leaf k's region: the x with low < x <= high."""
        return self._low[k].copy(), self._high[k].copy()

    @property
    def relevance(self) -> np.ndarray:
        """1 / length scale per input, in the inputs' own units, of the leaf that has learned the most."""
        return max(self._parts, key=lambda part: part.n_learned).relevance

    # --- learning ---------------------------------------------------------------------------
    def _leaf_of(self, x: np.ndarray) -> int:
        inside = np.all((x > self._low) & (x <= self._high), axis=1)
        return int(np.argmax(inside))  # exactly one box holds any x

    def _reaching(self, x: np.ndarray, parts: list[int] | None = None) -> list[int]:
        """The leaves that learn x: those whose box, widened by its overlap at each cut, holds it."""
        if parts is None and len(self._parts) == 1:
            return [0]  # one leaf: its box is everything
        rows = range(len(self._parts)) if parts is None else parts
        return [k for k in rows if np.all((x > self._reach_low[k]) & (x <= self._reach_high[k]))]

    def _learn_many(self, xs: np.ndarray, ys: np.ndarray, sources: list[str] | None = None) -> None:
        """Rows in order, as learn_one would; served live, each leaf's factor is rebuilt once at the end
        (gp_local.defer_factor), not per row, and a refit is due on schedule and on spread, not on surprise
        (which needs each row's answer)."""
        for part in self._parts:
            part.defer_factor(True)
        try:
            super()._learn_many(xs, ys, sources)
        finally:
            for part in self._parts:  # (leaves cut from a deferring one defer too)
                part.defer_factor(False)

    def _source_number(self, source: str | None) -> int:
        """The teacher's number: in the order first taught, the first MOST_SOURCES - 1 each their own, any
        later one the last's; a pair told no teacher is number 0's (a run's first teacher, as before teachers
        were told apart)."""
        if source is None:
            return 0
        if source in self._sources:
            return self._sources.index(source)
        if len(self._sources) < MOST_SOURCES:
            self._sources.append(source)
        return len(self._sources) - 1

    def _learn_one(self, x: np.ndarray, y: np.ndarray, source: str | None = None) -> None:
        number = self._source_number(source)
        for part in [self._parts[k] for k in self._reaching(x)]:
            part.learn_one(x, y, source=number)
            self._take_split(self._parts.index(part))

    def _take_split(self, k: int) -> None:
        """Apply a split leaf k's last fit proposed (gp_split), if there is room: served live, the fit that
        proposes it ends in the fitter's process, to be collected by the leaf's next call, learning or not."""
        part = self._parts[k]
        split, part.proposed_split = part.proposed_split, None
        if split is not None and len(self._parts) < self.leaves:
            self._cut(k, split.input, split.threshold, (split.left, split.right))

    def _cut(self, k: int, i: int, threshold: float, fits: tuple) -> bool:
        """Leaf k becomes its samples with x[i] <= threshold and the rest, each with the given fit (None:
        its own, started at once), each also keeping (and learning from now on) the samples within OVERLAP
        of the other side, so that answers near the cut see both sides; False when a side would be empty."""
        part = self._parts[k]
        xs = part.remembered_inputs()
        left = xs[:, i] <= threshold
        if left.all() or not left.any():
            return False
        band = min(1.0 / part.relevance[i], OVERLAP * float(np.ptp(xs[:, i])))
        sides = (xs[:, i] <= threshold + band, xs[:, i] > threshold - band)
        halves = [part.part(np.flatnonzero(side), fit) for side, fit in zip(sides, fits)]
        boxes = []
        for box, reach in ((self._low, self._reach_low), (self._high, self._reach_high)):
            boxes.append((box[k].copy(), reach[k].copy()))
        (low, reach_low), (high, reach_high) = boxes
        left_high, right_low, left_reach, right_reach = high.copy(), low.copy(), reach_high.copy(), reach_low.copy()
        left_high[i], right_low[i] = threshold, threshold
        left_reach[i], right_reach[i] = threshold + band, threshold - band
        self._parts[k:k + 1] = halves
        self._low = np.vstack([self._low[:k], low, right_low, self._low[k + 1:]])
        self._high = np.vstack([self._high[:k], left_high, high, self._high[k + 1:]])
        self._reach_low = np.vstack([self._reach_low[:k], reach_low, right_reach, self._reach_low[k + 1:]])
        self._reach_high = np.vstack([self._reach_high[:k], left_reach, reach_high, self._reach_high[k + 1:]])
        room = len(self._parts) < self.leaves
        for each in self._parts:
            each.may_split = room
        return True

    def holding(self, value: float, seed: int) -> GP:
        """A copy of this single-output GP, taught nothing but 0.0 so far, as it would be had every target
        been `value` (and built with `seed`): a GP taught one value never fits nor factors, so only its
        remembered targets, running statistics and taught range say what the value was (per_output shares
        one GP among outputs held still). The tree's taught mean becomes `value` itself, which learn_many
        would have reached to rounding."""
        leaf = self._parts[0]
        if self.n_out != 1 or len(self._parts) != 1 or leaf._factored:
            raise ValueError("only a one-output GP taught a single value can be held at another")
        twin = copy.deepcopy(self)  # as a snapshot is taken: fitting in the caller's thread
        twin._parts[0]._background = leaf._background  # served live, as this one (its fitting processes are up)
        target = np.array([float(value)])
        for each in (twin, twin._parts[0]):
            each.seed = int(seed)
            if each._n_learned:
                each._taught = TaughtRange(1)
                each._taught.learn(target)
                each._taught_mean = target.copy()
        leaf = twin._parts[0]
        leaf._ys[:leaf._m] = target
        if leaf._y_count:
            leaf._y_mean = target.copy()
        return twin

    def serve_live(self) -> None:
        """Every leaf fits in the fitter's process (gp_local.LocalGP.serve_live), and so do the halves of a split."""
        for part in self._parts:
            part.serve_live()

    def warm_served(self) -> None:
        for part in self._parts:
            part.warm_served()

    def land_upkeep(self, budget_s: float) -> int:
        """Each leaf's finished fit or search applied, and a split one proposes taken, until `budget_s` is spent."""
        return land_each(lambda: self._parts, budget_s, self._take_split)

    @property
    def upkeep_under_way(self) -> int:
        return sum(part.upkeep_under_way for part in list(self._parts))

    # --- prediction -------------------------------------------------------------------------
    def predict_one(self, x):
        x = np.asarray(x, dtype=np.float64)
        if x.shape != (self.n_in,) or not np.isfinite(x).all():
            return super().predict_one(x)  # raises the contract's error
        k = self._leaf_of(x) if len(self._parts) > 1 else 0  # one leaf holds every x
        part = self._parts[k]
        p = part.predict_one(x)
        if part.proposed_split is not None:
            self._take_split(k)
        shown = self._shown
        if ((x < shown.low).any() or (x > shown.high).any()) and part._fades():
            y = fade_toward(self._taught_mean, shown, part.fade_widths(shown.span), x[None, :], p.y[None, :])[0]
            return Prediction(y, p.confidence, p.interval)
        return p

    def _predict_many(self, xs: np.ndarray) -> Predictions:
        n = len(xs)
        y, confidence, interval = np.zeros((n, self.n_out)), np.zeros(n), np.full((n, self.n_out), np.inf)
        inside = np.all((xs[:, None, :] > self._low[None]) & (xs[:, None, :] <= self._high[None]), axis=2)
        leaf = inside.argmax(1)
        for k in np.unique(leaf):
            rows, part = leaf == k, self._parts[k]
            p = part.predict_many(xs[rows])
            y[rows], confidence[rows] = p.y, p.confidence
            if part._fades():  # beyond what the whole was shown, toward the mean of all (see _fades)
                y[rows] = fade_toward(self._taught_mean, self._shown, part.fade_widths(self._shown.span), xs[rows],
                                      p.y)
            if p.interval is not None:
                interval[rows] = p.interval
        return Predictions(y, confidence, interval)

    def _bound(self, y: np.ndarray) -> np.ndarray:
        return y  # each leaf holds what it does not trust

    def _fades(self) -> bool:
        # beyond what the whole was shown, an answer fades to the taught mean of all (a far leaf's own mean
        # may be a bound: a bang-bang teacher's side), by the answering leaf's widths, unless its map is
        # linear: done in the predict methods
        return False

    @property
    def n_broken(self) -> int:
        return self._n_broken + sum(part.n_broken for part in self._parts)


register("gp", GP)
