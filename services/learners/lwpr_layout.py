"""Where each piece of a receptive field lives in its flat float64 row.

A receptive field (RF) is one row of `rfs[output, slot, :]`. Keeping every RF in one
array, rather than one object or one array per field, lets a compiled kernel be called
with six arguments: numba's per-argument dispatch cost would otherwise dominate an
update that takes a microsecond. Every field is a scalar, an n-vector or an n-by-n
matrix (n = number of inputs; at most n projections are ever used), so offsets are
simple formulas of n.
"""
from __future__ import annotations


import numba as nb

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
