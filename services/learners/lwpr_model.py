"""LWPR's model as compiled structures, named as in Vijayakumar, D'Souza & Schaal (2005) and the reference
library: a model holds its hyper-parameters and, per output, a list of receptive fields; a receptive
field holds its centre, distance metric, partial least squares projections, local regression and the
statistics they are learned from. The kernels (lwpr_kernels) take the model whole.

Both are numba StructRefs: one Python object crosses into compiled code, whatever the model's size, and
their functions cache to disk like any other kernel. n is the number of inputs; at most n projections
are ever used, so per-projection vectors have n entries (the first n_reg in use) and projection r is
row r of U, P and the n-by-n statistics.
"""
from __future__ import annotations

import numba as nb
import numpy as np
from numba.core import types
from numba.experimental import structref
from numba.extending import typeof_impl
from numba.typed import List

# Reassociation lets LLVM vectorise the dot products; no-NaN/no-inf flags are left out
# on purpose because the kernels test for non-finite inputs and return inf intervals.
FAST_MATH = {"nsz", "arcp", "contract", "afn", "reassoc"}

# initial inverse covariance of the exact local fit: a ridge of 1e-8, small enough that nearly
# collinear inputs (the head reading echoing the commanded head, distractors drifting along with
# the tail) do not bias the fit; at 1e-4 it cost mirroring up to 9.5 s of teaching instead of 1.5 s
RLS_PRIOR = 1e8

_VECTOR, _MATRIX = types.float64[::1], types.float64[:, ::1]

FIELD_VECTORS = (
    "centre",  # c
    "mean_x", "var_x",  # forgetting weighted mean and variance of the inputs it learned from
    # per projection r (the first n_reg entries):
    "beta",  # regression coefficient of the projection s_r
    "ss_s2", "ss_yres",  # SS_r = sum w s_r^2, SR_r = sum w s_r res_r
    "sum_e_cv2", "sum_w", "n_data",  # cross-validated error, weight and sample count with r + 1 projections
    "lam",  # forgetting factor, annealed towards final_lambda
    "h_trace", "r_trace",  # the memory traces of the leave-one-out gradient
    "s_last",  # the projections s_r of the last sample
    "rls_theta",  # the exact fit's coefficients on [x - c, 1] (n + 1)
)
FIELD_MATRICES = (
    "M", "D",  # distance metric D = M'M, M upper triangular
    "alpha", "meta_b", "meta_h",  # M's learning rates, their meta-learned exp(b) and its memory trace
    "U", "P",  # projection directions u_r and input loadings p_r, one per row
    "ss_xres_yres", "ss_xres",  # sum w res z_r (u_r before normalising) and SZ_r = sum w z_r s_r
    "rls_inverse",  # the exact fit's inverse weighted covariance ((n + 1)-square)
)
FIELD_SCALARS = (
    "beta0",  # offset: forgetting weighted mean of y
    "sum_e2",  # forgetting sum of the training errors
)


@structref.register
class ReceptiveFieldType(types.StructRef):
    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


@structref.register
class LWPRModelType(types.StructRef):
    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


RECEPTIVE_FIELD = ReceptiveFieldType([("n_reg", types.int64)]
                                     + [(name, _VECTOR) for name in FIELD_VECTORS]
                                     + [(name, _MATRIX) for name in FIELD_MATRICES]
                                     + [(name, types.float64) for name in FIELD_SCALARS])
FIELDS = types.ListType(RECEPTIVE_FIELD)  # one output's receptive fields

# hyper-parameters as the kernels take them (LWPR's constructor names them and checks them)
HYPER_FLOATS = ("init_d", "init_alpha", "w_gen", "w_prune", "w_cutoff", "init_lambda", "final_lambda",
                "tau_lambda", "init_s2", "add_threshold", "add_min_data", "penalty", "meta_rate", "novelty_scale")
HYPER_INTS = ("init_reg", "max_reg", "max_rfs")
HYPER_FLAGS = ("diag_only", "update_d", "meta", "exact_fit")
LWPR_MODEL = LWPRModelType([("n_in", types.int64), ("outputs", types.ListType(FIELDS))]
                           + [(name, types.float64) for name in HYPER_FLOATS]
                           + [(name, types.int64) for name in HYPER_INTS]
                           + [(name, types.boolean) for name in HYPER_FLAGS])


class ReceptiveField(structref.StructRefProxy):
    """A receptive field seen from Python (its numbers are reached through the compiled functions)."""


class LWPRModel(structref.StructRefProxy):
    """An LWPR model seen from Python: hand it to the kernels whole."""


structref.define_boxing(ReceptiveFieldType, ReceptiveField)
structref.define_boxing(LWPRModelType, LWPRModel)
# numba's generic typeof first tries the buffer protocol, which fails by raising; the model crosses into
# compiled code on every call, so it is typed at once (its type never changes)
typeof_impl.register(LWPRModel)(lambda value, context: LWPR_MODEL)


@nb.njit(cache=True)
def copy_into(destination, source, at=0):
    """destination's entries from `at` on = source's, both C-contiguous, read in row-major order. A plain
    loop: numba's assignment of one 2-d array to another compiles for seconds at each use."""
    flat_destination, flat_source = destination.reshape(destination.size), source.reshape(source.size)
    for i in range(flat_source.shape[0]):
        flat_destination[at + i] = flat_source[i]


@nb.njit(cache=True)
def blank_field(n):
    """A receptive field of n inputs holding zeros, with no projection."""
    rf = structref.new(RECEPTIVE_FIELD)
    rf.n_reg = 0
    rf.centre, rf.mean_x, rf.var_x = np.zeros(n), np.zeros(n), np.zeros(n)
    rf.beta, rf.ss_s2, rf.ss_yres = np.zeros(n), np.zeros(n), np.zeros(n)
    rf.sum_e_cv2, rf.sum_w, rf.n_data, rf.lam = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
    rf.h_trace, rf.r_trace, rf.s_last = np.zeros(n), np.zeros(n), np.zeros(n)
    rf.M, rf.D = np.zeros((n, n)), np.zeros((n, n))
    rf.alpha, rf.meta_b, rf.meta_h = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    rf.U, rf.P = np.zeros((n, n)), np.zeros((n, n))
    rf.ss_xres_yres, rf.ss_xres = np.zeros((n, n)), np.zeros((n, n))
    rf.rls_theta, rf.rls_inverse = np.zeros(n + 1), np.zeros((n + 1, n + 1))
    rf.beta0, rf.sum_e2 = 0.0, 0.0
    return rf


@nb.njit(cache=True)
def new_model(n_in, n_out, floats, ints, flags):
    """A model with no receptive field; the hyper-parameters in the order of HYPER_FLOATS, _INTS, _FLAGS."""
    model = structref.new(LWPR_MODEL)
    model.n_in = n_in
    outputs = List.empty_list(FIELDS)
    for _ in range(n_out):
        outputs.append(List.empty_list(RECEPTIVE_FIELD))
    model.outputs = outputs
    (model.init_d, model.init_alpha, model.w_gen, model.w_prune, model.w_cutoff, model.init_lambda,
     model.final_lambda, model.tau_lambda, model.init_s2, model.add_threshold, model.add_min_data, model.penalty,
     model.meta_rate, model.novelty_scale) = floats
    model.init_reg, model.max_reg, model.max_rfs = ints
    model.diag_only, model.update_d, model.meta, model.exact_fit = flags
    return model
