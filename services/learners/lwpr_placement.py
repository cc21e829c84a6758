"""Where a receptive field sits in input space: made around an input, the squared distance that
sets its activation, whether an input lies beyond what it has seen, the size of its metric."""
from __future__ import annotations

import math

import numba as nb

from .lwpr_model import FAST_MATH, RLS_PRIOR, blank_field, copy_into
from .novelty import EXPERIENCED_SDS  # a field's experience: mean +- this many sd per input


@nb.njit(cache=True, fastmath=FAST_MATH)
def new_field(model, x):
    """A receptive field centred on x with the model's initial metric and learning rates."""
    n = x.shape[0]
    rf = blank_field(n)
    copy_into(rf.centre, x)
    copy_into(rf.mean_x, x)
    rf.lam[:] = model.init_lambda
    rf.ss_s2[:] = model.init_s2
    rf.sum_w[:] = 1e-10
    rf.n_data[:] = 1e-10
    for i in range(n):  # projections start along the axes until data says otherwise
        rf.U[i, i] = 1.0
        rf.P[i, i] = 1.0
    for i in range(n + 1):  # a weak ridge prior: the fit follows the data after a few samples
        rf.rls_inverse[i, i] = RLS_PRIOR
    for i in range(n):
        rf.D[i, i] = model.init_d
        rf.M[i, i] = math.sqrt(model.init_d)
    rf.alpha[:] = model.init_alpha
    rf.meta_b[:] = model.init_alpha  # exp of the meta log-rate b
    return rf


@nb.njit(cache=True, fastmath=FAST_MATH)
def inherit_metric(rf, nearest):
    """The nearest field's adapted metric and learning rates are the best guess for a new one."""
    copy_into(rf.M, nearest.M)
    copy_into(rf.D, nearest.D)
    copy_into(rf.alpha, nearest.alpha)
    copy_into(rf.meta_b, nearest.meta_b)


@nb.njit(cache=True, fastmath=FAST_MATH)
def squared_distance(rf, x, diag_only):
    """(x - c)' D (x - c): the receptive field's Mahalanobis distance to x."""
    c, d = rf.centre, rf.D
    n = x.shape[0]
    q = 0.0
    if diag_only:
        for i in range(n):
            dx = x[i] - c[i]
            q += d[i, i] * dx * dx
        return q
    for i in range(n):
        dxi = x[i] - c[i]
        row = 0.0
        for j in range(n):
            row += d[i, j] * (x[j] - c[j])
        q += dxi * row
    return q


@nb.njit(cache=True, fastmath=FAST_MATH)
def beyond_experience(rf, x, scale):
    """How far x lies outside the inputs this field has learned from, squared, in units of
    `scale`: per input, the distance beyond mean +- EXPERIENCED_SDS sd (forgetting, weighted).

    The activation alone cannot tell novelty along an input that never varied: the metric
    only narrows along inputs that matter to the output, so a value never seen there (an
    orange ball, after teaching with pink only) barely lowers it."""
    mean, var = rf.mean_x, rf.var_x
    q = 0.0
    for i in range(x.shape[0]):
        excess = abs(x[i] - mean[i]) - EXPERIENCED_SDS * math.sqrt(var[i])
        if excess > 0.0:
            q += excess * excess
    return q / (scale * scale)


@nb.njit(cache=True, fastmath=FAST_MATH)
def trace_d(rf):
    d = rf.D
    t = 0.0
    for i in range(d.shape[0]):
        t += d[i, i]
    return t
