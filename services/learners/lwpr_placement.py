"""Where a receptive field sits in input space: made around an input, the squared distance that
sets its activation, whether an input lies beyond what it has seen, the size of its metric."""
from __future__ import annotations

import math

import numba as nb

from .lwpr_layout import (
    ALPHA, CENTRE, FAST_MATH, HP_INIT_ALPHA, HP_INIT_D, HP_INIT_LAMBDA, HP_INIT_S2, LAMBDA, MEAN_X, META_B,
    METRIC_D, METRIC_M, N_DATA, P_LOAD, RLS_PRIOR, SS_S2, SUM_W, U_DIR, VAR_X, mat, rls_inverse, vec,
)
from .novelty import EXPERIENCED_SDS  # a field's experience: mean +- this many sd per input


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
