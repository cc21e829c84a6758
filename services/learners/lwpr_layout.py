"""Where each piece of a receptive field lives in its flat float64 row.

A receptive field (RF) is one row of `rfs[output, slot, :]`. Keeping every RF in one
array, rather than one object or one array per field, lets a compiled kernel be called
with six arguments: numba's per-argument dispatch cost would otherwise dominate an
update that takes a microsecond. Every field is a scalar, an n-vector or an n-by-n
matrix (n = number of inputs; at most n projections are ever used), so offsets are
simple formulas of n.
"""
from __future__ import annotations

import math

import numba as nb

from .novelty import EXPERIENCED_SDS  # a field's experience: mean +- this many sd per input

# Reassociation lets LLVM vectorise the dot products; no-NaN/no-inf flags are left out
# on purpose because the kernels test for non-finite inputs and return inf intervals.
FAST_MATH = {"nsz", "arcp", "contract", "afn", "reassoc"}

# --- scalars
BETA0, SUM_E2 = 0, 1
N_SCALARS = 4  # two spare slots keep room for additions without changing offsets of vectors

# --- n-vectors (projection-indexed ones use the first n_reg entries)
(CENTRE, MEAN_X, VAR_X, BETA, SS_S2, SS_YRES, SUM_E_CV2, SUM_W, N_DATA, LAMBDA,
 H_TRACE, R_TRACE, S_LAST) = range(13)
N_VECTORS = 13

# --- n-by-n matrices, row-major (projection-indexed ones: row i is projection i);
# META_B holds exp(b), the meta-learned rate before any halving
(METRIC_M, METRIC_D, ALPHA, META_B, META_H, U_DIR, P_LOAD, SS_XRES_YRES, SS_XRES) = range(9)
N_MATRICES = 9

# --- hyper-parameter vector handed to the kernels
(HP_W_GEN, HP_W_PRUNE, HP_W_CUTOFF, HP_INIT_LAMBDA, HP_FINAL_LAMBDA, HP_TAU_LAMBDA,
 HP_INIT_S2, HP_ADD_THRESHOLD, HP_PENALTY, HP_META_RATE, HP_DIAG_ONLY, HP_META,
 HP_UPDATE_D, HP_INIT_D, HP_INIT_ALPHA, HP_MAX_REG, HP_ADD_MIN_DATA, HP_INIT_REG,
 HP_MAX_RFS, HP_EXACT_FIT, HP_NOVELTY_SCALE) = range(21)
N_HP = 21


# initial inverse covariance of the exact local fit: a ridge of 1e-8, small enough that nearly
# collinear inputs (the head reading echoing the commanded head, distractors drifting along with
# the tail) do not bias the fit; at 1e-4 it cost mirroring up to 9.5 s of teaching instead of 1.5 s
RLS_PRIOR = 1e8


def floats_per_rf(n: int) -> int:
    """Length of one receptive field's row for n inputs."""
    return N_SCALARS + N_VECTORS * n + N_MATRICES * n * n + (n + 1) * (n + 2)


@nb.njit(cache=True, inline="always", fastmath=FAST_MATH)
def vec(st, field, n):
    start = N_SCALARS + field * n
    return st[start:start + n]


@nb.njit(cache=True, inline="always", fastmath=FAST_MATH)
def mat(st, field, n):
    start = N_SCALARS + N_VECTORS * n + field * n * n
    return st[start:start + n * n]


@nb.njit(cache=True, inline="always", fastmath=FAST_MATH)
def rls_theta(st, n):
    """Coefficients of the exact local fit on [x - c, 1] (n + 1 entries)."""
    start = N_SCALARS + N_VECTORS * n + N_MATRICES * n * n
    return st[start:start + n + 1]


@nb.njit(cache=True, inline="always", fastmath=FAST_MATH)
def rls_inverse(st, n):
    """Its (n + 1)-square inverse weighted covariance, row-major."""
    start = N_SCALARS + N_VECTORS * n + N_MATRICES * n * n + n + 1
    return st[start:start + (n + 1) * (n + 1)]


@nb.njit(cache=True, fastmath=FAST_MATH)
def init_rf(st, n, x, template, hp):
    """Blank receptive field centred on x; metric and learning rates from `template` if given."""
    st[:] = 0.0
    vec(st, CENTRE, n)[:] = x
    vec(st, MEAN_X, n)[:] = x
    vec(st, LAMBDA, n)[:] = hp[HP_INIT_LAMBDA]
    vec(st, SS_S2, n)[:] = hp[HP_INIT_S2]
    vec(st, SUM_W, n)[:] = 1e-10
    vec(st, N_DATA, n)[:] = 1e-10
    u, p = mat(st, U_DIR, n), mat(st, P_LOAD, n)
    for i in range(n):  # projections start along the axes until data says otherwise
        u[i * n + i] = 1.0
        p[i * n + i] = 1.0
    inverse = rls_inverse(st, n)
    for i in range(n + 1):  # a weak ridge prior: the fit follows the data after a few samples
        inverse[i * (n + 1) + i] = RLS_PRIOR
    if template.shape[0] > 0:
        for field in (METRIC_M, METRIC_D, ALPHA, META_B):
            mat(st, field, n)[:] = mat(template, field, n)
        return
    m, d = mat(st, METRIC_M, n), mat(st, METRIC_D, n)
    for i in range(n):
        d[i * n + i] = hp[HP_INIT_D]
        m[i * n + i] = math.sqrt(hp[HP_INIT_D])
    mat(st, ALPHA, n)[:] = hp[HP_INIT_ALPHA]
    mat(st, META_B, n)[:] = hp[HP_INIT_ALPHA]  # exp of the meta log-rate b


@nb.njit(cache=True, fastmath=FAST_MATH)
def squared_distance(st, n, x, diag_only):
    """(x - c)' D (x - c): the receptive field's Mahalanobis distance to x."""
    c, d = vec(st, CENTRE, n), mat(st, METRIC_D, n)
    q = 0.0
    if diag_only:
        for i in range(n):
            dx = x[i] - c[i]
            q += d[i * n + i] * dx * dx
        return q
    for i in range(n):
        dxi = x[i] - c[i]
        row = 0.0
        for j in range(n):
            row += d[i * n + j] * (x[j] - c[j])
        q += dxi * row
    return q


@nb.njit(cache=True, fastmath=FAST_MATH)
def beyond_experience(st, n, x, scale):
    """How far x lies outside the inputs this field has learned from, squared, in units of
    `scale`: per input, the distance beyond mean +- EXPERIENCED_SDS sd (forgetting, weighted).

    The activation alone cannot tell novelty along an input that never varied: the metric
    only narrows along inputs that matter to the output, so a value never seen there (an
    orange ball, after teaching with pink only) barely lowers it."""
    mean, var = vec(st, MEAN_X, n), vec(st, VAR_X, n)
    q = 0.0
    for i in range(n):
        excess = abs(x[i] - mean[i]) - EXPERIENCED_SDS * math.sqrt(var[i])
        if excess > 0.0:
            q += excess * excess
    return q / (scale * scale)


@nb.njit(cache=True, fastmath=FAST_MATH)
def trace_d(st, n):
    d = mat(st, METRIC_D, n)
    t = 0.0
    for i in range(n):
        t += d[i * n + i]
    return t

