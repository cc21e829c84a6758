"""The learner contract (river's habits): hyper-parameters in the constructor under their
own names, learned state in `_underscore` attributes, one-sample verbs, and every
prediction carrying its confidence.

A subclass declares its hyper-parameters as keyword arguments of `__init__` (immutable
defaults), stores them under the same names, and implements `_reset`, `_learn_one`,
`_predict_many` and `size`. Validation, batching, cloning and snapshots come from here.
"""
from __future__ import annotations

import inspect
import time
from typing import NamedTuple

import numba as nb
import numpy as np

from . import snapshot_codec
from .inputs import as_matrix, as_vector
from .snapshot_codec import SnapshotError  # noqa: F401 - where callers have imported it from


class Prediction(NamedTuple):
    y: np.ndarray  # (n_out,) float64
    confidence: float  # in [0, 1]: how well the query is supported by experience
    interval: np.ndarray | None = None  # (n_out,) one-sigma predictive half-width, if known


class Predictions(NamedTuple):
    y: np.ndarray  # (n, n_out)
    confidence: np.ndarray  # (n,)
    interval: np.ndarray | None = None  # (n, n_out)


MAX_SOURCE_CHARS = 256


@nb.njit(cache=True, nogil=True)
def within(values, low, high):
    """Whether low <= values <= high everywhere (compiled: a taught range asks it of every pair, 15 times a tick
    in the mirroring learner; LWPR of every input)."""
    for i in range(values.shape[0]):
        if values[i] < low[i] or values[i] > high[i]:
            return False
    return True


class TaughtRange:
    """Per output, the range of the values taught. An answer is held within it plus MARGIN of its
    span: whatever a model makes of few or collinear samples, the robot is never sent far beyond
    what it was shown. An output never taught is not held."""

    MARGIN = 0.1

    def __init__(self, n_out: int):
        self.low, self.high = np.full(n_out, np.inf), np.full(n_out, -np.inf)
        self.floor, self.ceiling = np.full(n_out, -np.inf), np.full(n_out, np.inf)

    def learn(self, ys: np.ndarray) -> None:
        if ys.shape == self.low.shape and ys.dtype == np.float64 and ys.flags.writeable and ys.flags.c_contiguous:
            # one row, as most are learned (a read-only or strided one, a payload's, would have numba compile
            # another signature on the tick: numpy's way below)
            if within(ys, self.low, self.high):  # nothing changes
                return
            low = high = ys
        else:
            ys = ys.reshape(-1, len(self.low))
            if len(ys) == 0:
                return
            low, high = (ys[0], ys[0]) if len(ys) == 1 else (ys.min(0), ys.max(0))
        # a value within the range changes nothing: the common case costs two comparisons
        if not ((low < self.low).any() or (high > self.high).any()):
            return
        self.low, self.high = np.minimum(self.low, low), np.maximum(self.high, high)
        self.refresh()

    def refresh(self) -> None:
        """Floor and ceiling from low and high (after a compiled kernel widened those in place)."""
        span = self.high - self.low
        self.floor, self.ceiling = self.low - self.MARGIN * span, self.high + self.MARGIN * span

    @property
    def span(self) -> np.ndarray:
        """high - low; 0 for an output never taught."""
        return np.where(self.high >= self.low, self.high - self.low, 0.0)

    def bound(self, y: np.ndarray) -> np.ndarray:
        return np.clip(y, self.floor, self.ceiling)

    def middle(self) -> np.ndarray:
        return np.where(self.high >= self.low, (self.low + self.high) / 2, 0.0)


# Beyond the inputs it was shown, a student's answer fades to the taught mean. Each input's width is FADE
# of its taught span past its edge; the answer holds for FADE_HOLD widths, then fades over FADE_OVER more
# (exp(-d^2 / 2), d the excess past the hold in FADE_OVER widths, summed over inputs): 4 % of its departure
# from the mean is left 3.5 widths out. Not sooner: a student a little past what it was shown often still
# knows (CartPole's teacher keeps the pole within +-0.04 rad, its episodes start anywhere within +-0.05:
# faded from the edge over a tenth of the span, or a half, the student pushed one way from the start and
# the pole fell within 22 steps, in 2 to 4 episodes of 6; faded from the edge over a whole span, the worst
# of 20 random maps 10 s into their teaching (benchmarks/unknown.py) erred 0.218 where unfaded it erred
# 0.188, and the ball-seeking student turned too little towards an orange ball at a bearing it was never
# shown, reaching it in 48 episodes of 50 where unfaded it reached all). A model's trend
# (a linear part, a local linear fit, the nearest sample's answer) carried away from the teaching drives
# the robot to its bounds where it was never shown them: a pendulum student held full torque and spun it
# for minutes. The taught mean is the answer with the least expected distance to everything taught and
# never an extreme unless every lesson was; a hold means nothing to a learner (what is still for a torque?),
# and a default controller, where there is one, already drives when the student is unsure (arbitration).
# Inputs that never varied while taught (their span under JITTER_SHARE of the median's) do not count: the
# paper's orange ball, new along a colour input, is chased like the pink one while the robot asks.
FADE, FADE_HOLD, FADE_OVER, JITTER_SHARE = 1.0, 2.0, 0.6, 1e-3


class Learner:
    """Base of every learner; see the module docstring for what a subclass provides."""

    # classes of the learner's own state that its snapshot may hold (besides arrays, plain values and the
    # common ones: services.learners.snapshot_codec)
    state_classes: tuple[type, ...] = ()
    # learn_one / learn_many take who taught each pair (`source`, `sources`: a teacher's name, as the pairs on the
    # bus say it), to weigh each teacher as consistent as it shows itself (gp: each teacher's own noise)
    learns_sources = False

    def __init__(self, n_in: int, n_out: int, seed: int = 0):
        if int(n_in) < 1 or int(n_out) < 1:
            raise ValueError(f"n_in and n_out must be positive, got {n_in} and {n_out}")
        self.n_in = int(n_in)
        self.n_out = int(n_out)
        self.seed = int(seed)
        self._n_learned = 0
        self._taught = TaughtRange(self.n_out)
        self._shown = TaughtRange(self.n_in)  # the inputs' range while taught (FADE)
        self._taught_mean, self._taught_count = np.zeros(self.n_out), 0
        self._n_broken = 0  # answers the model gave as NaN or inf, replaced by _sane

    # --- the contract -------------------------------------------------------------
    def learn_one(self, x, y, source: str | None = None) -> None:
        """Learn one (input, target) pair in place; `source`, who taught it, where the learner `learns_sources`."""
        x = as_vector(x, self.n_in, "inputs")
        y = as_vector(y, self.n_out, "outputs")
        if source is not None:
            self._learn_one(x, y, source=self._checked_source(source))
        else:
            self._learn_one(x, y)
        self._taught.learn(y)
        self._note_shown(x, y)
        self._n_learned += 1

    def learn_many(self, xs, ys, sources=None) -> None:
        """Learn rows in order; all rows are checked before any is learned. `sources`: who taught each row,
        where the learner `learns_sources`."""
        xs = as_matrix(xs, self.n_in, "inputs")
        ys = as_matrix(ys, self.n_out, "outputs", rows=xs.shape[0])
        if sources is not None:
            sources = list(sources)
            if len(sources) != len(xs):
                raise ValueError(f"sources must name the teacher of each of the {len(xs)} rows, got {len(sources)}")
            self._learn_many(xs, ys, sources=[self._checked_source(source) for source in sources])
        else:
            self._learn_many(xs, ys)
        self._taught.learn(ys)
        self._note_shown(xs, ys)
        self._n_learned += xs.shape[0]

    def _checked_source(self, source):
        """A teacher's name, checked: a string of at most MAX_SOURCE_CHARS, told to a learner that
        `learns_sources`."""
        if not self.learns_sources:
            raise TypeError(f"{type(self).__name__} does not tell its teachers apart: teach it without a source")
        if not isinstance(source, str) or len(source) > MAX_SOURCE_CHARS:
            raise ValueError(f"source must be a teacher's name of at most {MAX_SOURCE_CHARS} characters, got "
                             f"{str(source)[:40]!r}")
        return source

    def _note_shown(self, xs: np.ndarray, ys: np.ndarray) -> None:
        """The inputs' taught range and the outputs' running mean (FADE), for rows or one pair."""
        self._shown.learn(xs.reshape(-1, self.n_in))
        self._note_taught_mean(ys)

    def _note_taught_mean(self, ys: np.ndarray) -> None:
        """The outputs' running mean over every pair taught (FADE), for rows or one pair."""
        if ys.ndim == 1:  # one pair: ys.sum(0) is ys, 1 * the mean the mean
            self._taught_count += 1
            self._taught_mean = self._taught_mean + (ys - self._taught_mean) / self._taught_count
            return
        ys = ys.reshape(-1, self.n_out)
        self._taught_count += len(ys)
        self._taught_mean = self._taught_mean + (ys.sum(0) - len(ys) * self._taught_mean) / self._taught_count

    def predict_one(self, x) -> Prediction:
        x = as_vector(x, self.n_in, "inputs")
        many = self._sane(self._predict_many(x[None, :]), x[None, :])
        interval = None if many.interval is None else many.interval[0]
        return Prediction(many.y[0], float(many.confidence[0]), interval)

    def predict_many(self, xs) -> Predictions:
        xs = as_matrix(xs, self.n_in, "inputs")
        return self._sane(self._predict_many(xs), xs)

    def _sane(self, p: Predictions, xs: np.ndarray | None = None) -> Predictions:
        """Answers beyond the inputs shown faded to the taught mean (FADE; when `xs`, the queries, are
        given), held to the taught range (`_bound`), and never NaN or inf: a row a model could not
        answer gets the middle of the taught range with confidence 0 (its model is at fault; the
        robot must not be)."""
        y = p.y if xs is None else self._fade(xs, p.y)
        y, confidence = self._bound(y), np.nan_to_num(p.confidence, nan=0.0, posinf=0.0, neginf=0.0)
        broken = ~np.isfinite(y).all(axis=1)
        if broken.any():
            y = np.where(broken[:, None], self._taught.middle(), y)
            confidence = np.where(broken, 0.0, confidence)
            self._n_broken += int(broken.sum())
        return Predictions(y, np.clip(confidence, 0.0, 1.0), p.interval)

    def _sane_one(self, y: np.ndarray, confidence: float, interval: np.ndarray | None,
                  x: np.ndarray | None = None) -> Prediction:
        """`_sane` for one answer, for learners with a fast predict_one of their own (x: the query)."""
        many = self._sane(Predictions(y[None, :], np.array([confidence]), None if interval is None else interval[None,
                                                                                                                 :]),
                          None if x is None else x[None, :])
        return Prediction(many.y[0], float(many.confidence[0]), None if interval is None else many.interval[0])

    def _bound(self, y: np.ndarray) -> np.ndarray:
        """Hold answers to the taught range; a learner with a rule of its own overrides this."""
        return self._taught.bound(y)

    def _fade(self, xs: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Each row of y toward the taught mean by how far its query lies beyond the inputs shown, over FADE
        of each varied input's span."""
        span = self._shown.span
        if not span.any() or not self._fades():
            return y
        return fade_toward(self._taught_mean, self._shown, self._fade_widths(span), xs, y)

    def _fade_widths(self, span: np.ndarray) -> np.ndarray:
        """Per input, the width over which answers fade beyond what was shown: FADE of its taught span,
        none (inf) for an input that never varied; a learner that knows which inputs matter widens it
        along those that do not (a distractor beyond its range changes nothing)."""
        moved = span[span > 0.0]
        return np.where(span > JITTER_SHARE * np.median(moved), FADE * span, np.inf)

    def _fades(self) -> bool:
        """Whether answers beyond the inputs shown fade (FADE); a learner that knows its map goes on (the GP
        of a linear one) says no."""
        return True

    def serve_live(self) -> None:
        """A service is about to serve a live loop with this learner: one whose upkeep can take long
        (the GP's fits) moves it off the caller's thread. Offline use stays deterministic."""

    def warm_served(self) -> None:
        """Run once the compiled kernels only serving live uses (the GP's answer from alpha and a float32 factor),
        so that compile_kernels builds them before a service says it is ready; nothing else changes."""

    def land_upkeep(self, budget_s: float) -> int:
        """Apply upkeep finished in the background (the GP's fits and splits) now, for about `budget_s` (at least
        one job), rather than at the next call that needs it, so that a job's result (a fit with its factor) is not
        held until its part of the model is taught or asked again. Returns the jobs applied; offline always 0. The
        learner service does not call it (withdrawn, docs/learners.md: the hierarchy's gait walked less with it)."""
        return 0

    @property
    def upkeep_under_way(self) -> int:
        """Jobs of upkeep (the GP's fits) still running on another thread: 0 once every answer from now on
        reflects everything taught (a finished job is applied at the next call that needs it; served live;
        offline always 0)."""
        return 0

    @property
    def n_learned(self) -> int:
        return self._n_learned

    @property
    def n_broken(self) -> int:
        """Answers the model itself gave as NaN or inf (the robot got the taught middle, unsure)."""
        return self._n_broken

    @property
    def size(self) -> int:
        raise NotImplementedError

    # --- what subclasses implement --------------------------------------------------
    def _learn_one(self, x: np.ndarray, y: np.ndarray) -> None:
        raise NotImplementedError

    def _learn_many(self, xs: np.ndarray, ys: np.ndarray, sources: list[str] | None = None) -> None:
        if sources is None:
            for x, y in zip(xs, ys):
                self._learn_one(x, y)
        else:
            for x, y, source in zip(xs, ys, sources):
                self._learn_one(x, y, source=source)

    def _predict_many(self, xs: np.ndarray) -> Predictions:
        raise NotImplementedError

    # --- free with the contract -------------------------------------------------------
    @classmethod
    def _unit_test_params(cls) -> dict:
        """Hyper-parameters that keep the conformance checks quick (river's habit)."""
        return {}

    @classmethod
    def param_names(cls) -> list[str]:
        """Hyper-parameter names: the keyword arguments of __init__ after n_in, n_out, seed."""
        names = list(inspect.signature(cls.__init__).parameters)
        return [name for name in names if name not in ("self", "n_in", "n_out", "seed")]

    def get_params(self) -> dict:
        return {name: getattr(self, name) for name in self.param_names()}

    def clone(self) -> Learner:
        """A fresh, unlearned learner with the same sizes, seed and hyper-parameters."""
        return type(self)(self.n_in, self.n_out, seed=self.seed, **self.get_params())

    def snapshot(self) -> bytes:
        """The learner as data only (services.learners.snapshot_codec): arrays, numbers, known classes."""
        return snapshot_codec.dump(self)

    @classmethod
    def restore(cls, blob: bytes) -> Learner:
        """A learner from `snapshot()` bytes, which may come from the bus: only arrays, plain values and
        the learners' registered state classes are built, then the learner must answer a probe with
        finite numbers; anything else is a SnapshotError (the swapping learner learns the history)."""
        model = snapshot_codec.load(blob, cls)
        try:
            probe = model.predict_many(np.zeros((2, model.n_in)))
            sane = np.isfinite(probe.y).all() and np.isfinite(probe.confidence).all()
        except Exception as err:  # noqa: BLE001 - state that does not fit together is a refused snapshot
            raise SnapshotError(f"the snapshot's {type(model).__name__} does not answer: "
                                f"{type(err).__name__}: {err}") from None
        if not sane:
            raise SnapshotError(f"the snapshot's {type(model).__name__} answers with non-finite numbers")
        return model

    def __setstate__(self, state: dict) -> None:
        # a snapshot taken before an attribute existed (a hyper-parameter, a piece of learned state)
        # gets what a fresh learner of this version, with the snapshot's hyper-parameters, starts with
        self.__dict__.update(state)
        params = {name: state[name] for name in self.param_names() if name in state}
        for name, value in vars(type(self)(self.n_in, self.n_out, seed=self.seed, **params)).items():
            self.__dict__.setdefault(name, value)

    def __repr__(self) -> str:
        params = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}(n_in={self.n_in}, n_out={self.n_out}, seed={self.seed}, {params})"


def land_each(parts, budget_s: float, after=None) -> int:
    """Learner.land_upkeep over a model's parts in turn (`parts()`, asked again after each: a split changes them),
    until `budget_s` is spent once something landed; `after(k)` follows part k's landing (the tree takes its split)."""
    end, landed, k = time.monotonic() + budget_s, 0, 0
    while k < len(current := parts()):
        done = current[k].land_upkeep(max(0.0, end - time.monotonic()))
        if done and after is not None:
            after(k)
        landed, k = landed + done, k + 1
        if landed and time.monotonic() >= end:
            break
    return landed


def fade_toward(mean: np.ndarray, shown: TaughtRange, width: np.ndarray, xs: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Rows of y toward `mean` by exp(-d^2 / 2), d how far each query lies beyond the range `shown` past
    FADE_HOLD, in units of FADE_OVER `width` per input (inf: that input does not count)."""
    if not np.all(shown.high >= shown.low):
        return y  # nothing shown yet
    counted = np.isfinite(width)
    excess = np.maximum(np.maximum(shown.low - xs, xs - shown.high), 0.0)[:, counted] / width[counted]
    past_hold = np.maximum(excess - FADE_HOLD, 0.0)
    if not past_hold.any():
        return y
    weight = np.exp(-0.5 * ((past_hold / FADE_OVER) ** 2).sum(1))
    return mean + weight[:, None] * (y - mean)
