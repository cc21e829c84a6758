"""Locally Weighted Projection Regression (Vijayakumar, D'Souza & Schaal, Neural
Computation 17(12), 2005): Gaussian receptive fields, each an incremental partial least
squares regression, created where no field is active (w < w_gen), pruned where two
overlap (w > w_prune), each adapting its distance metric by gradient descent on its
leave-one-out cost. The model is one compiled structure (lwpr_model) that the compiled
kernels (lwpr_kernels) take whole; this class checks hyper-parameters and inputs, and turns
the model into arrays for snapshots (lwpr_snapshot).
"""
from __future__ import annotations

import numpy as np

from .base import Learner, Prediction, Predictions
from .inputs import as_matrix, as_vector, check_positive, check_range, kernel_ready
from .errors import LearnerInputError
from .registry import register

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
        self._model = self._new_model()

    def _hyper_parameters(self) -> dict:
        """Validated hyper-parameters as the kernels take them (ValueError names a bad one)."""
        n = self.n_in
        hp = {"init_d": default_init_d(n) if self.init_D is None else check_positive("init_D", self.init_D)}
        hp["init_alpha"] = check_positive("init_alpha", self.init_alpha)
        hp["w_gen"] = check_range("w_gen", self.w_gen, 0.0, 1.0)
        hp["w_prune"] = check_range("w_prune", self.w_prune, 0.0, 1.0)
        hp["w_cutoff"] = check_range("w_cutoff", self.w_cutoff, 0.0, 1.0)
        hp["init_lambda"] = check_range("init_lambda", self.init_lambda, 0.5, 1.0 - 1e-12)
        hp["final_lambda"] = check_range("final_lambda", self.final_lambda, 0.5, 1.0 - 1e-12)
        hp["tau_lambda"] = check_range("tau_lambda", self.tau_lambda, 0.0, 1.0)
        hp["init_s2"] = check_positive("init_S2", self.init_S2)
        hp["add_threshold"] = check_range("add_threshold", self.add_threshold, 0.0, 1.0)
        min_data = 2.0 * n if self.add_min_data is None else self.add_min_data
        hp["add_min_data"] = check_positive("add_min_data", min_data, strictly=False)
        # projection counts beyond the number of inputs mean 'all of them'
        hp["init_reg"] = min(n, int(check_positive("init_reg", self.init_reg)))
        max_reg = n if self.max_reg is None else self.max_reg
        hp["max_reg"] = min(n, int(check_positive("max_reg", max_reg)))
        hp["penalty"] = check_positive("penalty", self.penalty, strictly=False)
        hp["meta_rate"] = check_positive("meta_rate", self.meta_rate, strictly=False)
        hp["max_rfs"] = int(check_positive("max_rfs", self.max_rfs))
        for name in ("diag_only", "update_D", "meta", "exact_fit"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise ValueError(f"hyper-parameter {name} must be True or False, got {getattr(self, name)!r}")
            hp[name.lower()] = bool(getattr(self, name))
        # 0 turns it off: confidence is then the activation alone
        hp["novelty_scale"] = check_positive("novelty_scale", self.novelty_scale, strictly=False)
        return hp

    def _new_model(self):
        """A compiled model (lwpr_model.LWPRModel) with these hyper-parameters and no receptive field."""
        from . import lwpr_model as m

        _kernels()  # its cache checked first
        hp = self._hyper_parameters()
        return m.new_model(self.n_in, self.n_out, tuple(hp[name] for name in m.HYPER_FLOATS),
                           tuple(hp[name] for name in m.HYPER_INTS), tuple(hp[name] for name in m.HYPER_FLAGS))

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
        kernels, taught, shown = _loaded_kernels or _kernels(), self._taught, self._shown
        status = kernels.learn_one(self._model, x, y, raw, taught.low, taught.high, shown.low, shown.high)
        if status < 0:
            self._reject(status, x, y)
        if status & kernels.TAUGHT_WIDENED:  # the kernel widened the range in place
            taught.refresh()
        if status & kernels.SHOWN_WIDENED:
            shown.refresh()
        self._note_taught_mean(y)
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
        status, row = _kernels().learn_many(self._model, xs, ys)
        if status < 0:  # a row the kernel refused: those before it are learned
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

    # --- prediction -----------------------------------------------------------------
    def predict_one(self, x) -> Prediction:
        x = raw = kernel_ready(x)
        if x.shape != (self.n_in,):
            as_vector(x, self.n_in, "inputs")
        if self._input_scale is not None:
            x = x * self._input_scale
        kernels, taught, shown = _loaded_kernels or _kernels(), self._taught, self._shown
        y, interval = np.empty(self.n_out), np.empty(self.n_out)
        confidence, beyond = kernels.predict_one(self._model, x, y, interval, taught.floor, taught.ceiling,
                                                 raw, shown.low, shown.high)
        if confidence == -1.0:  # the kernel found a non-finite input
            as_vector(x, self.n_in, "inputs")
        if confidence == -2.0:  # an answer the model could not give
            return self._sane_one(y, 0.0, interval)
        if beyond:  # beyond the inputs shown: fade (base.FADE)
            y = taught.bound(self._fade(raw[None, :], y[None, :])[0])
        # tuple.__new__ skips NamedTuple's Python-level __new__: 0.2 µs of a 2.5 µs call
        return _new_tuple(Prediction, (y, confidence, interval))

    def _predict_many(self, xs: np.ndarray) -> Predictions:
        xs = kernel_ready(xs) if self._input_scale is None else xs * self._input_scale
        ys, confidence, intervals = _kernels().predict_many(self._model, xs)
        return Predictions(ys, confidence, intervals)

    def _fade_widths(self, span: np.ndarray) -> np.ndarray:
        """base.FADE, and no narrower along an input than the fields' own width there (1 / sqrt(D_ii) of the
        narrowest field, in the input's units): the metric learns which inputs matter, and a distractor
        moving beyond its taught range (a leg, while the head mirrors the tail) must not fade the answer."""
        widths = super()._fade_widths(span)
        if self.size == 0:
            return widths
        sharpest = _kernels().sharpest_metric(self._model)
        with np.errstate(divide="ignore"):
            field = 1.0 / np.sqrt(sharpest)
        if self._input_scale is not None:
            field = field / self._input_scale
        return np.maximum(widths, field)

    # --- introspection and snapshots ----------------------------------------------------
    @property
    def size(self) -> int:
        """Receptive fields over all outputs."""
        return sum(self.rfs_per_output)

    @property
    def rfs_per_output(self) -> list[int]:
        return _kernels().field_counts(self._model).tolist()

    def __getstate__(self) -> dict:
        """The compiled model as arrays (lwpr_snapshot), under the names the flat-array version kept them:
        a snapshot loads in either version."""
        from . import lwpr_snapshot

        state = dict(self.__dict__)
        del state["_model"]
        state["_rfs"], state["_nreg"], state["_n_rfs"] = lwpr_snapshot.pack(self._model)
        return state

    def __setstate__(self, state: dict) -> None:
        from . import lwpr_snapshot

        state = dict(state)
        state.pop("_hp", None)  # the flat-array version's hyper-parameter vector: made again from them
        try:
            rows, n_reg, counts = (state.pop(name) for name in ("_rfs", "_nreg", "_n_rfs"))
        except KeyError:
            raise ValueError("an LWPR snapshot without its receptive fields (_rfs, _nreg, _n_rfs)") from None
        rows, n_reg, counts = (np.ascontiguousarray(a, dtype=dtype) for a, dtype in
                               ((rows, np.float64), (n_reg, np.int64), (counts, np.int64)))
        super().__setstate__(state)
        lwpr_snapshot.check_rows(rows, n_reg, counts, self.n_in, self.n_out)
        self._model = self._new_model()
        lwpr_snapshot.unpack(self._model, rows, n_reg, counts)
        for ranges in (self._taught, self._shown):  # learn_one's kernel widens them in place
            ranges.low, ranges.high = np.array(ranges.low, dtype=np.float64), np.array(ranges.high, dtype=np.float64)
            ranges.refresh()  # writeable floor and ceiling too: a read-only array would compile the kernel again


register("lwpr", LWPR)
