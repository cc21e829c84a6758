"""Compiled one-sample paths of the GP (gp.py): a kernel row, appending a sample to the Cholesky
factor, and a prediction, each O(m^2) for m remembered samples with no allocation beyond a row.

The kernel, on inputs multiplied by their inverse length scales (z = x inv_ell), is the unit
squared exponential weighted by `smooth` plus a linear part `linear` (z - zc).(z' - zc) around the
taught inputs' centre (the two weights are the fit's shares of the prior variance);
`chol` is the lower Cholesky factor of K + ratio I over the remembered inputs, and
`beta` = chol^-1 (y - mu) per output, so that the posterior mean at x is mu + (chol^-1 k) . beta.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

FAST_MATH = {"nsz", "arcp", "contract", "afn", "reassoc"}


@nb.njit(cache=True, fastmath=FAST_MATH)
def kernel_row(xs, m, x, inv_ell, centre, smooth, linear, out):
    """out[j] = k(x, xs[j]) for the first m rows of xs; returns k(x, x)."""
    prior = 0.0
    for i in range(x.shape[0]):
        away = (x[i] - centre[i]) * inv_ell[i]
        prior += away * away
    for j in range(m):
        d2 = 0.0
        dot = 0.0
        for i in range(x.shape[0]):
            diff = (x[i] - xs[j, i]) * inv_ell[i]
            d2 += diff * diff
            dot += (x[i] - centre[i]) * (xs[j, i] - centre[i]) * inv_ell[i] * inv_ell[i]
        out[j] = smooth * math.exp(-0.5 * d2) + linear * dot
    return smooth + linear * prior


@nb.njit(cache=True, fastmath=FAST_MATH)
def forward(chol, m, b, out):
    """Solve chol[:m, :m] out = b[:m] (lower triangular); returns out . out."""
    total = 0.0
    for i in range(m):
        acc = b[i]
        for j in range(i):
            acc -= chol[i, j] * out[j]
        out[i] = acc / chol[i, i]
        total += out[i] * out[i]
    return total


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def append(xs, chol, beta, m, x, residual, inv_ell, centre, smooth, linear, ratio, before):
    """Add sample m (already in xs[m]) with targets-minus-mean `residual` to chol and beta.

    Fills before[k] with the posterior mean offset (v . beta_k) the model gave x before learning it
    and returns the unit posterior variance there (k(x, x) + ratio - v . v, at least ratio): the
    prequential test of what the learner would have said."""
    k = np.empty(m)
    v = np.empty(m)
    prior = kernel_row(xs, m, x, inv_ell, centre, smooth, linear, k)
    explained = forward(chol, m, k, v)
    # rounding can make a near-duplicate's pivot vanish; the noise ratio is its floor
    pivot2 = max(prior + ratio - explained, ratio)
    pivot = math.sqrt(pivot2)
    for j in range(m):
        chol[m, j] = v[j]
        chol[j, m] = 0.0
    chol[m, m] = pivot
    for o in range(beta.shape[1]):
        acc = 0.0
        for j in range(m):
            acc += v[j] * beta[j, o]
        before[o] = acc
        beta[m, o] = (residual[o] - acc) / pivot
    return pivot2


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def predict_one(xs, chol, beta, m, x, inv_ell, centre, smooth, linear, ratio, offset):
    """Fills offset[k] = v . beta_k; returns the unit posterior variance k(x, x) + ratio - v . v."""
    k = np.empty(m)
    v = np.empty(m)
    prior = kernel_row(xs, m, x, inv_ell, centre, smooth, linear, k)
    explained = forward(chol, m, k, v)
    for o in range(beta.shape[1]):
        acc = 0.0
        for j in range(m):
            acc += v[j] * beta[j, o]
        offset[o] = acc
    return max(prior + ratio - explained, ratio)
