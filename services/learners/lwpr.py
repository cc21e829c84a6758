"""Locally Weighted Projection Regression (Vijayakumar, D'Souza & Schaal, Neural
Computation 17(12), 2005): Gaussian receptive fields, each an incremental partial least
squares regression, created where no field is active (w < w_gen), pruned where two
overlap (w > w_prune), each adapting its distance metric by gradient descent on its
leave-one-out cost. The numerics live in compiled kernels (lwpr_kernels); this class
holds the state, checks inputs and grows storage.
"""
from __future__ import annotations

import numpy as np

from . import lwpr_layout as layout
from .base import (
    Learner, Prediction, Predictions, as_matrix, as_vector, check_positive, check_range, kernel_ready,
)
from .errors import LearnerInputError
from .registry import register

_INITIAL_SLOTS = 4
_new_tuple = tuple.__new__


_loaded_kernels = None


def _kernels():
    # imported on first use so that importing services.learners stays fast
    global _loaded_kernels
    if _loaded_kernels is None:
        from .kernel_cache import drop_stale_numba_cache

        drop_stale_numba_cache()
        from . import lwpr_kernels
        _loaded_kernels = lwpr_kernels
    return _loaded_kernels


def default_init_d(n: int) -> float:
    """The initial width for n unit-scaled inputs. In one or two, the reference's 25: fields are cheap
    there and detail needs them narrow (4 / n left the untuned cross at 0.31 nMSE). From three on,
    4 / n: one field spans the data along irrelevant inputs yet starts local enough to adapt (narrower
    starts in 3 inputs kept adding fields on a stationary stream: docs/learners.md)."""
    return 25.0 if n <= 2 else 4.0 / n


class LWPR(Learner):
    """LWPR; confidence is the strongest receptive field's activation (weakest output),
    lowered where the input lies beyond what that field has learned from (novelty_scale)."""

    def __init__(self, n_in: int, n_out: int, seed: int = 0, *,
                 init_D: float | None = None, init_alpha: float = 250.0,
                 w_gen: float = 0.1, w_prune: float = 1.0, w_cutoff: float = 0.001,
                 init_lambda: float = 0.995, final_lambda: float = 0.99999,
                 tau_lambda: float = 0.9999, init_S2: float = 1e-10,
                 add_threshold: float = 0.5, add_min_data: float | None = None,
                 init_reg: int = 2, max_reg: int | None = None, penalty: float = 1e-6,
                 diag_only: bool = True, update_D: bool = True, meta: bool = True,
                 meta_rate: float = 250.0, max_rfs: int = 200, exact_fit: bool = True,
                 norm_in: float | tuple[float, ...] = 1.0, novelty_scale: float = 0.25):
        super().__init__(n_in, n_out, seed)
        self.init_D = init_D
        self.init_alpha = init_alpha
        self.w_gen, self.w_prune, self.w_cutoff = w_gen, w_prune, w_cutoff
        self.init_lambda, self.final_lambda, self.tau_lambda = init_lambda, final_lambda, tau_lambda
        self.init_S2 = init_S2
        self.add_threshold, self.add_min_data = add_threshold, add_min_data
        self.init_reg, self.max_reg = init_reg, max_reg
        self.penalty = penalty
        self.diag_only, self.update_D = diag_only, update_D
        self.meta, self.meta_rate = meta, meta_rate
        self.max_rfs = max_rfs
        self.exact_fit = exact_fit
        self.norm_in = norm_in
        self.novelty_scale = novelty_scale
        self._input_scale = self._input_scale_from_norm()
        self._hp = self._hyper_parameter_vector()
        self._reset()

    def _hyper_parameter_vector(self) -> np.ndarray:
        """Validated hyper-parameters packed for the kernels (ValueError names a bad one)."""
        n = self.n_in
        hp = np.zeros(layout.N_HP)
        init_d = default_init_d(n) if self.init_D is None else check_positive("init_D", self.init_D)
        hp[layout.HP_INIT_D] = init_d
        hp[layout.HP_INIT_ALPHA] = check_positive("init_alpha", self.init_alpha)
        hp[layout.HP_W_GEN] = check_range("w_gen", self.w_gen, 0.0, 1.0)
        hp[layout.HP_W_PRUNE] = check_range("w_prune", self.w_prune, 0.0, 1.0)
        hp[layout.HP_W_CUTOFF] = check_range("w_cutoff", self.w_cutoff, 0.0, 1.0)
        hp[layout.HP_INIT_LAMBDA] = check_range("init_lambda", self.init_lambda, 0.5, 1.0 - 1e-12)
        hp[layout.HP_FINAL_LAMBDA] = check_range("final_lambda", self.final_lambda, 0.5, 1.0 - 1e-12)
        hp[layout.HP_TAU_LAMBDA] = check_range("tau_lambda", self.tau_lambda, 0.0, 1.0)
        hp[layout.HP_INIT_S2] = check_positive("init_S2", self.init_S2)
        hp[layout.HP_ADD_THRESHOLD] = check_range("add_threshold", self.add_threshold, 0.0, 1.0)
        min_data = 2.0 * n if self.add_min_data is None else self.add_min_data
        hp[layout.HP_ADD_MIN_DATA] = check_positive("add_min_data", min_data, strictly=False)
        # projection counts beyond the number of inputs mean 'all of them'
        hp[layout.HP_INIT_REG] = min(n, int(check_positive("init_reg", self.init_reg)))
        max_reg = n if self.max_reg is None else self.max_reg
        hp[layout.HP_MAX_REG] = min(n, int(check_positive("max_reg", max_reg)))
        hp[layout.HP_PENALTY] = check_positive("penalty", self.penalty, strictly=False)
        hp[layout.HP_META_RATE] = check_positive("meta_rate", self.meta_rate, strictly=False)
        hp[layout.HP_MAX_RFS] = int(check_positive("max_rfs", self.max_rfs))
        for name in ("diag_only", "update_D", "meta", "exact_fit"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise ValueError(f"hyper-parameter {name} must be True or False, got {getattr(self, name)!r}")
        hp[layout.HP_DIAG_ONLY] = float(self.diag_only)
        hp[layout.HP_UPDATE_D] = float(self.update_D)
        hp[layout.HP_META] = float(self.meta)
        hp[layout.HP_EXACT_FIT] = float(self.exact_fit)
        # 0 turns it off: confidence is then the activation alone
        hp[layout.HP_NOVELTY_SCALE] = check_positive("novelty_scale", self.novelty_scale, strictly=False)
        return hp

    def _input_scale_from_norm(self) -> np.ndarray | None:
        """1 / norm_in per input, or None when inputs are used as they are.

        Widths and the metric are in normalised units: inputs whose typical range is far
        from 1 (pixels, millimetres) should be divided by that range, as in the reference."""
        norm = np.asarray(self.norm_in, dtype=np.float64)
        if norm.shape not in ((), (self.n_in,)) or not np.all(np.isfinite(norm) & (norm > 0)):
            raise ValueError(f"hyper-parameter norm_in must be a positive number or {self.n_in} of them, "
                             f"got {self.norm_in!r}")
        if np.all(norm == 1.0):
            return None
        return np.broadcast_to(1.0 / norm, (self.n_in,)).copy()

    def _reset(self) -> None:
        slots = min(_INITIAL_SLOTS, int(self._hp[layout.HP_MAX_RFS]))
        self._rfs = np.zeros((self.n_out, slots, layout.floats_per_rf(self.n_in)))
        self._nreg = np.zeros((self.n_out, slots), dtype=np.int64)
        self._n_rfs = np.zeros(self.n_out, dtype=np.int64)

    # --- learning ---------------------------------------------------------------------
    def learn_one(self, x, y) -> None:
        x, y = kernel_ready(x), kernel_ready(y)
        raw = x
        if x.shape != (self.n_in,) or y.shape != (self.n_out,):
            as_vector(x, self.n_in, "inputs")  # raises with the right message
            as_vector(y, self.n_out, "outputs")
        if self._input_scale is not None:
            with np.errstate(over="ignore"):  # an overflow is refused below, with its reason
                x = x * self._input_scale
        kernels, taught = _loaded_kernels or _kernels(), self._taught
        status = kernels.learn_one(self._rfs, self._nreg, self._n_rfs, self._hp, x, y, taught.low, taught.high)
        while status == 1:
            self._grow()
            status = kernels.learn_one(self._rfs, self._nreg, self._n_rfs, self._hp, x, y, taught.low, taught.high)
        if status < 0:
            self._reject(status, x, y)
        if status == 2:  # the kernel widened the taught range
            taught.refresh()
        self._note_shown(raw, y)
        self._n_learned += 1

    def learn_many(self, xs, ys) -> None:
        xs = raw = kernel_ready(as_matrix(xs, self.n_in, "inputs"))
        ys = kernel_ready(as_matrix(ys, self.n_out, "outputs", rows=xs.shape[0]))
        if self._input_scale is not None:
            with np.errstate(over="ignore"):
                xs = xs * self._input_scale
            overflowed = np.argwhere(~np.isfinite(xs))  # every row checked before any is learned
            if len(overflowed):
                row, column = overflowed[0]
                self._reject(-1 - int(column), xs[row], ys[row])
        kernels = _kernels()
        row = 0
        while row < xs.shape[0]:
            status, row = kernels.learn_many(self._rfs, self._nreg, self._n_rfs, self._hp, xs, ys, row)
            if status == 1:
                self._grow()
            elif status < 0:  # a row the kernel refused: never retried for ever
                self._n_learned += row
                self._reject(status, xs[row], ys[row])
        self._taught.learn(ys)
        self._note_shown(raw, ys)
        self._n_learned += xs.shape[0]

    def _reject(self, status: int, x: np.ndarray, y: np.ndarray) -> None:
        index = -status - 1
        if index < self.n_in:
            scaled = "" if self._input_scale is None else f" once divided by norm_in ({self.norm_in!r})"
            raise LearnerInputError(f"input {index} is {x[index]}{scaled}; learners need finite numbers")
        index -= self.n_in
        raise LearnerInputError(f"output {index} is {y[index]}; learners need finite numbers")

    def _grow(self) -> None:
        """Double the slots per output (up to max_rfs); fields keep their place."""
        slots = self._rfs.shape[1]
        new_slots = min(int(self._hp[layout.HP_MAX_RFS]), 2 * slots)
        rfs = np.zeros((self.n_out, new_slots, self._rfs.shape[2]))
        rfs[:, :slots] = self._rfs
        nreg = np.zeros((self.n_out, new_slots), dtype=np.int64)
        nreg[:, :slots] = self._nreg
        self._rfs, self._nreg = rfs, nreg

    # --- prediction -----------------------------------------------------------------
    def predict_one(self, x) -> Prediction:
        x = raw = kernel_ready(x)
        if x.shape != (self.n_in,):
            as_vector(x, self.n_in, "inputs")
        if self._input_scale is not None:
            x = x * self._input_scale
        kernels, taught = _loaded_kernels or _kernels(), self._taught
        y, interval = np.empty(self.n_out), np.empty(self.n_out)
        confidence = kernels.predict_one(self._rfs, self._nreg, self._n_rfs, self._hp, x, y, interval,
                                         taught.floor, taught.ceiling)
        if confidence == -1.0:  # the kernel found a non-finite input
            as_vector(x, self.n_in, "inputs")
        if confidence == -2.0:  # an answer the model could not give
            return self._sane_one(y, 0.0, interval)
        shown = self._shown
        if (raw < shown.low).any() or (raw > shown.high).any():  # beyond what was shown: fade (base.FADE)
            y = taught.bound(self._fade(raw[None, :], y[None, :])[0])
        # tuple.__new__ skips NamedTuple's Python-level __new__: 0.2 µs of a 2.5 µs call
        return _new_tuple(Prediction, (y, confidence, interval))

    def _predict_many(self, xs: np.ndarray) -> Predictions:
        xs = kernel_ready(xs) if self._input_scale is None else xs * self._input_scale
        ys, confidence, intervals = _kernels().predict_many(self._rfs, self._nreg, self._n_rfs, self._hp, xs)
        return Predictions(ys, confidence, intervals)

    def _fade_widths(self, span: np.ndarray) -> np.ndarray:
        """base.FADE, and no narrower along an input than the fields' own width there (1 / sqrt(D_ii) of the
        narrowest field, in the input's units): the metric learns which inputs matter, and a distractor
        moving beyond its taught range (a leg, while the head mirrors the tail) must not fade the answer."""
        widths = super()._fade_widths(span)
        n, used = self.n_in, int(self._n_rfs.max(initial=0))
        if used == 0:
            return widths
        start = layout.N_SCALARS + layout.N_VECTORS * n + layout.METRIC_D * n * n
        diagonal = self._rfs[:, :used, start:start + n * n][:, :, ::n + 1]  # (outputs, fields, n): D_ii
        alive = np.arange(used)[None, :] < self._n_rfs[:, None]
        sharpest = np.where(alive[:, :, None], diagonal, 0.0).max(axis=(0, 1))
        with np.errstate(divide="ignore"):
            field = 1.0 / np.sqrt(sharpest)
        if self._input_scale is not None:
            field = field / self._input_scale
        return np.maximum(widths, field)

    # --- introspection and snapshots ----------------------------------------------------
    @property
    def size(self) -> int:
        """Receptive fields over all outputs."""
        return int(self._n_rfs.sum())

    @property
    def rfs_per_output(self) -> list[int]:
        return [int(n) for n in self._n_rfs]

    def __getstate__(self) -> dict:
        # only used slots travel in a snapshot
        state = dict(self.__dict__)
        used = max(1, int(self._n_rfs.max()))
        state["_rfs"] = self._rfs[:, :used].copy()
        state["_nreg"] = self._nreg[:, :used].copy()
        return state

    def __setstate__(self, state: dict) -> None:
        super().__setstate__(state)
        self._hp = self._hyper_parameter_vector()  # the kernels' layout of this version
        taught = self._taught  # learn_one's kernel widens its range in place
        taught.low, taught.high = np.array(taught.low, dtype=np.float64), np.array(taught.high, dtype=np.float64)
        taught.refresh()  # writeable floor and ceiling too: a read-only array would compile the kernel again


register("lwpr", LWPR)
