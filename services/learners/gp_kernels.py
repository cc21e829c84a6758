"""Compiled one-sample paths of the GP (gp.py): a kernel row, appending a sample to the Cholesky
factor, and a prediction, each O(m^2) for m remembered samples with no allocation beyond a row.

The kernel, on inputs multiplied by their inverse length scales (z = x inv_ell), is the unit
squared exponential weighted by `smooth` plus a linear part `linear` (z - zc).(z' - zc) around the
taught inputs' centre (the two weights are the fit's shares of the prior variance);
`chol` is the lower Cholesky factor of K + ratio R^-1 over the remembered inputs (R: how many times
each was taught, gp_repeats.REPEATS_COUNTED at most; I until one is taught again), and
`beta` = chol^-1 (y - mu) per output, so that the posterior mean at x is mu + (chol^-1 k) . beta.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from .novelty import EXPERIENCED_SDS

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
    for j in range(m):  # the upper triangle is zero already (every factor written is lower triangular): a
        chol[m, j] = v[j]  # column of writes a row apart took half the call at 800 samples
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


@nb.njit(cache=True, nogil=True)  # no fast-math: the same rounding as LocalGP._answer's numpy
def answer_one(offset, unit_var, mu, amplitude2, ratio, near_span, hold, floor, ceiling, x, envelope_mean,
               envelope_sd, counted, novelty_scale, ramp, y, sd):
    """One query's answer from its posterior offsets and unit variance, as LocalGP._answer gives it: y the
    mean (held to [floor, ceiling] when `hold`), sd the predictive sd per output; returns the confidence:
    erf(near_span / map sd) for the least sure output, times the envelope's novelty discount along the
    `counted` inputs (novelty.InputEnvelope.beyond_inputs; novelty_scale 0: none) and `ramp`."""
    map_var = max(unit_var - ratio, 0.0)
    confidence = 1.0
    for o in range(offset.shape[0]):
        sd[o] = math.sqrt(unit_var * amplitude2[o])
        map_sd = math.sqrt(map_var * amplitude2[o])
        sure = math.erf(near_span[o] / map_sd) if map_sd > 0.0 else 1.0
        confidence = min(confidence, sure)
        value = mu[o] + offset[o]
        y[o] = min(max(value, floor[o]), ceiling[o]) if hold else value
    if novelty_scale > 0.0:
        total = 0.0
        for i in range(x.shape[0]):
            if counted[i]:
                excess = max(abs(x[i] - envelope_mean[i]) - EXPERIENCED_SDS * envelope_sd[i], 0.0)
                total += excess * excess
        confidence *= math.exp(-0.5 * total / (novelty_scale * novelty_scale))
    return confidence * ramp


@nb.njit(cache=True, nogil=True)
def same_place(xs, ys, m, x, y, x_tolerance, y_tolerance, others):
    """Of the first m rows, those with |xs[j] - x| <= x_tolerance everywhere (the same place): returns the
    first whose |ys[j] - y| <= y_tolerance too (the same lesson), or -1, and how many of the others (another
    answer there) it wrote into `others`."""
    same, count = -1, 0
    for j in range(m):
        here = True
        for i in range(x.shape[0]):
            if not abs(xs[j, i] - x[i]) <= x_tolerance[i]:
                here = False
                break
        if not here:
            continue
        agrees = True
        for o in range(y.shape[0]):
            if not abs(ys[j, o] - y[o]) <= y_tolerance[o]:
                agrees = False
                break
        if agrees and same < 0:
            same = j
        elif not agrees:
            others[count] = j
            count += 1
    return same, count


@nb.njit(cache=True, nogil=True)
def reweigh(chol, m, j, delta):
    """chol, the lower factor of K, becomes that of K + delta e_j e_j^T (row j's noise changed by delta): a
    rank-one update, or downdate for delta < 0. False, chol as good as lost, when rounding leaves the
    result not positive definite: rebuild it."""
    sign = 1.0 if delta > 0.0 else -1.0
    carry = np.zeros(m)
    carry[j] = math.sqrt(abs(delta))
    for k in range(j, m):
        pivot2 = chol[k, k] * chol[k, k] + sign * carry[k] * carry[k]
        if not pivot2 > 0.0:
            return False
        pivot = math.sqrt(pivot2)
        c, s = pivot / chol[k, k], carry[k] / chol[k, k]
        chol[k, k] = pivot
        for i in range(k + 1, m):
            chol[i, k] = (chol[i, k] + sign * s * carry[i]) / c
            carry[i] = c * carry[i] - s * chol[i, k]
    return True


@nb.njit(cache=True, nogil=True)
def resolve(chol, beta, residual, m, start):
    """beta = chol^-1 residual again, from row `start` on (the rows before it unchanged)."""
    for i in range(start, m):
        for o in range(beta.shape[1]):
            acc = residual[i, o]
            for k in range(i):
                acc -= chol[i, k] * beta[k, o]
            beta[i, o] = acc / chol[i, i]


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def gram(xs, m, inv_ell, centre, smooth, linear, out):
    """The lower triangle (diagonal included) of the kernel matrix over the first m rows of xs, into
    out[:m, :m], each entry as kernel_row computes it; the upper triangle is left as it was."""
    n = xs.shape[1]
    z = np.empty((m, n))
    for j in range(m):
        for i in range(n):
            z[j, i] = (xs[j, i] - centre[i]) * inv_ell[i]
    for a in range(m):
        for b in range(a + 1):
            d2 = 0.0
            dot = 0.0
            for i in range(n):
                diff = z[a, i] - z[b, i]
                d2 += diff * diff
                dot += z[a, i] * z[b, i]
            out[a, b] = smooth * math.exp(-0.5 * d2) + linear * dot
