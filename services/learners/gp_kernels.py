"""Compiled one-sample paths of the GP (gp.py): a kernel row, appending a sample to the Cholesky
factor, and a prediction, each O(m^2) for m remembered samples with no allocation beyond a row.

The kernel, on inputs multiplied by their inverse length scales (z = x inv_ell), is the unit
squared exponential weighted by `smooth` plus a linear part `linear` (z - zc).(z' - zc) around the
taught inputs' centre (the two weights are the fit's shares of the prior variance);
`chol` is the lower Cholesky factor of K + ratio R^-1 over the remembered inputs (R: how many times
each was taught, gp_repeats.REPEATS_COUNTED at most; I until one is taught again), and
`beta` = chol^-1 (y - mu) per output, so that the posterior mean at x is mu + (chol^-1 k) . beta.

Served live, an answer reads no float64 factor (issue 34): its mean is mu + k . alpha, alpha = chol^-T beta
(solved again after learning, O(m^2), off the answer path), and its variance comes from a float32 copy of
the factor, half the bytes, 5x faster at 800 samples. Offline (predict_exact) every answer is as ever.
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
    """Solve chol[:m, :m] out = b[:m] (lower triangular); returns out . out (summed in float64 whatever the dtype)."""
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
def predict_exact(xs, chol, beta, m, x, inv_ell, centre, smooth, linear, ratio, offset):
    """Offline (every replay and benchmark, to the last bit): fills offset[k] = v . beta_k, v = chol^-1 k; returns
    the unit posterior variance k(x, x) + ratio - v . v."""
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


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def predict_one(xs, chol32, alpha, m, x, inv_ell, centre, smooth, linear, ratio, offset):
    """Fills offset[k] = k . alpha_k (alpha = chol^-T beta: the posterior mean offset); returns the unit
    posterior variance k(x, x) + ratio - v . v, v = chol^-1 k solved in float32 (chol32)."""
    k = np.empty(m)
    prior = kernel_row(xs, m, x, inv_ell, centre, smooth, linear, k)
    k32 = np.empty(m, dtype=np.float32)
    for j in range(m):
        k32[j] = k[j]
    explained = forward(chol32, m, k32, np.empty(m, dtype=np.float32))  # its float32 signature: float32 sums
    offset[:] = k @ alpha[:m]
    return max(prior + ratio - explained, ratio)


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def back_solve(chol, beta, m, alpha):
    """alpha[:m] = chol[:m, :m]^-T beta[:m], row by row of chol from the last (each row read once, in order)."""
    n_out = beta.shape[1]
    work = np.empty((n_out, m))
    for o in range(n_out):
        for i in range(m):
            work[o, i] = beta[i, o]
    for j in range(m - 1, -1, -1):
        for o in range(n_out):
            a = work[o, j] / chol[j, j]
            work[o, j] = a
            for i in range(j):
                work[o, i] -= chol[j, i] * a
    for o in range(n_out):
        for i in range(m):
            alpha[i, o] = work[o, i]


@nb.njit(cache=True, nogil=True)
def copy32(chol, chol32, start, m):
    """Rows start..m-1 of the factor's lower triangle into its float32 copy."""
    for i in range(start, m):
        for j in range(i + 1):
            chol32[i, j] = chol[i, j]


@nb.njit(cache=True, nogil=True, error_model="numpy")  # no fast-math: numpy's numbers
def input_sd(mean, scatter, count, out):
    """Each input's sd over `count` rows from the envelope's mean and scatter, 0 where under 1e-12 of 1 + |mean|
    (an input that never varied: rounding is not spread; LocalGP._input_sd)."""
    for i in range(mean.shape[0]):
        sd = math.sqrt(scatter[i, i] / max(count, 1))
        out[i] = sd if sd > 1e-12 * (1.0 + abs(mean[i])) else 0.0


@nb.njit(cache=True, nogil=True)  # no fast-math: the same rounding as LocalGP._amplitude2's numpy
def map_prior(o, fitted_scale, y_sum_sq, counted_y, low, high):
    """Output o's prior variance of the map (LocalGP._amplitude2, fitted_scale = exp(2 log_sf), counted_y the targets
    counted, at least 1) and its taught span."""
    span = high[o] - low[o] if high[o] >= low[o] else 0.0
    half = span / 2
    return max(fitted_scale * y_sum_sq[o] / counted_y, half * half), span


@nb.njit(cache=True, nogil=True, error_model="numpy")
def surprise(error, unit_var, log_sf, y_sum_sq, y_count, low, high):
    """The least expected output's squared standardised error, error^2 / (unit_var prior variance), 0 where the error
    is 0, at most 25 (gp_fitting.Refitting._weigh_surprise)."""
    fitted_scale, counted_y = math.exp(2.0 * log_sf), max(y_count, 1)
    most = -np.inf
    for o in range(error.shape[0]):
        amplitude2, _ = map_prior(o, fitted_scale, y_sum_sq, counted_y, low, high)
        most = max(most, error[o] * error[o] / (unit_var * amplitude2) if error[o] != 0.0 else 0.0)
    return min(most, 25.0)


@nb.njit(cache=True, nogil=True)  # no fast-math: the same rounding as LocalGP._answer's numpy
def answer_one(offset, unit_var, mu, ratio, log_sf, y_sum_sq, y_count, low, high, floor, ceiling, near, hold, x,
               envelope_mean, envelope_scatter, envelope_count, varied, novelty_scale, ramp, y, sd):
    """One query's answer from its posterior offsets and unit variance, as LocalGP._answer gives it, from the
    leaf's state as it is (no constants kept between calls): y the mean (held to [floor, ceiling] when `hold`),
    sd the predictive sd per output; returns the confidence: erf(near * span / (sqrt 2 map sd)) for the least sure
    output (the map's prior variance LocalGP._amplitude2's), times the envelope's novelty discount along the
    inputs no fit saw vary, every input where none did (novelty.InputEnvelope.beyond_inputs; novelty_scale or an
    empty envelope: none) and `ramp`."""
    map_var = max(unit_var - ratio, 0.0)
    fitted_scale, counted_y = math.exp(2.0 * log_sf), max(y_count, 1)
    confidence = 1.0
    for o in range(offset.shape[0]):
        amplitude2, span = map_prior(o, fitted_scale, y_sum_sq, counted_y, low, high)
        sd[o] = math.sqrt(unit_var * amplitude2)
        map_sd = math.sqrt(map_var * amplitude2)
        sure = math.erf(near * span / math.sqrt(2.0) / map_sd) if map_sd > 0.0 else 1.0
        confidence = min(confidence, sure)
        value = mu[o] + offset[o]
        y[o] = min(max(value, floor[o]), ceiling[o]) if hold else value
    if novelty_scale > 0.0 and envelope_count > 0:
        any_varied = False
        for i in range(varied.shape[0]):
            any_varied = any_varied or varied[i]
        total = 0.0
        for i in range(x.shape[0]):
            if not (any_varied and varied[i]):
                sd_i = math.sqrt(max(envelope_scatter[i, i], 0.0) / envelope_count)
                excess = max(abs(x[i] - envelope_mean[i]) - EXPERIENCED_SDS * sd_i, 0.0)
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
