"""Compiled SOGP update and prediction (see sogp.py for the algorithm).

State: basis vectors bv (cap+1, n_in), alpha (cap+1, n_out), C and Q (cap+1, cap+1),
count[0] = number of basis vectors in use; params = (k**, length scale, noise, tolerance,
capacity). One spare row lets a new basis vector in before the least useful goes out.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

KSS, SCALE, NOISE, TOL, CAPACITY = range(5)
FAST_MATH = {"nsz", "arcp", "contract", "afn", "reassoc"}


@nb.njit(cache=True, fastmath=FAST_MATH)
def kernel_row(bv, m, x, params, out):
    inv = 0.5 / params[SCALE] ** 2
    for j in range(m):
        d2 = 0.0
        for i in range(x.shape[0]):
            diff = x[i] - bv[j, i]
            d2 += diff * diff
        out[j] = params[KSS] * math.exp(-d2 * inv)


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def learn(bv, alpha, c, q, count, params, x, y):
    m = count[0]
    k, ck, e_hat = np.empty(m + 1), np.zeros(m + 1), np.zeros(m + 1)
    kernel_row(bv, m, x, params, k)
    var, gamma = params[KSS], params[KSS]
    for i in range(m):
        for j in range(m):
            ck[i] += c[i, j] * k[j]
            e_hat[i] += q[i, j] * k[j]
        var += k[i] * ck[i]
        gamma -= k[i] * e_hat[i]
    # the posterior variance lies in [0, k**]; rounding can push it out, and a negative
    # one would turn the next step into a huge one
    denom = params[NOISE] + min(max(var, 0.0), params[KSS])
    dr = -1.0 / denom
    dq = np.empty(alpha.shape[1])  # first derivative of the log evidence, per output
    for o in range(alpha.shape[1]):
        mean = 0.0
        for i in range(m):
            mean += k[i] * alpha[i, o]
        dq[o] = (y[o] - mean) / denom
    if m > 0 and gamma < params[TOL] * params[KSS]:
        for i in range(m):  # x is explained by the current basis: projected update
            ck[i] += e_hat[i]
        rank_one(alpha, c, ck, dq, dr, m)
        return
    add_basis_vector(bv, alpha, c, q, m, x, ck, e_hat, dq, dr, max(gamma, 1e-12))
    count[0] = m + 1
    if m + 1 > params[CAPACITY]:
        remove(bv, alpha, c, q, count, least_useful(alpha, c, q, m + 1))


@nb.njit(cache=True, fastmath=FAST_MATH)
def rank_one(alpha, c, s, dq, dr, m):
    """alpha += s dq', C += dr s s' over the first m basis vectors."""
    for i in range(m):
        for o in range(alpha.shape[1]):
            alpha[i, o] += s[i] * dq[o]
        for j in range(i, m):  # one triangle, mirrored: C stays exactly symmetric
            value = c[i, j] + dr * s[i] * s[j]
            c[i, j] = value
            c[j, i] = value


@nb.njit(cache=True, fastmath=FAST_MATH)
def add_basis_vector(bv, alpha, c, q, m, x, ck, e_hat, dq, dr, gamma):
    bv[m, :] = x
    alpha[m, :] = 0.0
    c[m, : m + 1] = 0.0
    c[: m + 1, m] = 0.0
    q[m, : m + 1] = 0.0
    q[: m + 1, m] = 0.0
    ck[m] = 1.0
    e_hat[m] = -1.0
    rank_one(alpha, c, ck, dq, dr, m + 1)
    for i in range(m + 1):  # inverse Gram matrix grown by the new vector
        for j in range(i, m + 1):
            value = q[i, j] + e_hat[i] * e_hat[j] / gamma
            q[i, j] = value
            q[j, i] = value


@nb.njit(cache=True, fastmath=FAST_MATH)
def least_useful(alpha, c, q, m):
    """The basis vector whose removal changes the posterior mean least."""
    best, best_score = 0, math.inf
    for i in range(m):
        a2 = 0.0
        for o in range(alpha.shape[1]):
            a2 += alpha[i, o] ** 2
        score = a2 / max(q[i, i] + c[i, i], 1e-12)
        if score < best_score:
            best, best_score = i, score
    return best


@nb.njit(cache=True, fastmath=FAST_MATH)
def remove(bv, alpha, c, q, count, i):
    """Project basis vector i out of the posterior (Csato & Opper, eq. 3.19-3.21)."""
    last = count[0] - 1
    swap(bv, alpha, c, q, i, last)
    inv_q = 1.0 / max(q[last, last], 1e-12)  # Q is positive definite; rounding aside
    c_star = c[last, last]
    q_col, c_col = q[:last, last].copy(), c[:last, last].copy()  # contiguous copies
    for r in range(last):
        for o in range(alpha.shape[1]):
            alpha[r, o] -= q_col[r] * alpha[last, o] * inv_q
    for r in range(last):
        qr, cr = q_col[r] * inv_q, c_col[r] * inv_q
        for s in range(r, last):  # symmetric updates, written to both triangles
            c_value = c[r, s] + c_star * qr * q_col[s] * inv_q - qr * c_col[s] - cr * q_col[s]
            q_value = q[r, s] - qr * q_col[s]
            c[r, s], c[s, r] = c_value, c_value
            q[r, s], q[s, r] = q_value, q_value
    count[0] = last


@nb.njit(cache=True)
def swap(bv, alpha, c, q, i, j):
    if i == j:
        return
    for a in (bv, alpha):
        for col in range(a.shape[1]):
            a[i, col], a[j, col] = a[j, col], a[i, col]
    for mat in (c, q):
        for col in range(mat.shape[1]):
            mat[i, col], mat[j, col] = mat[j, col], mat[i, col]
        for row in range(mat.shape[0]):
            mat[row, i], mat[row, j] = mat[row, j], mat[row, i]


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def predict(bv, alpha, c, count, params, xs):
    """Posterior means (n, n_out) and latent variances (n,)."""
    m = count[0]
    means = np.zeros((xs.shape[0], alpha.shape[1]))
    variances = np.empty(xs.shape[0])
    k = np.empty(m)
    for row in range(xs.shape[0]):
        kernel_row(bv, m, xs[row], params, k)
        var = params[KSS]
        for i in range(m):
            ck = 0.0
            for j in range(m):
                ck += c[i, j] * k[j]
            var += k[i] * ck
            for o in range(alpha.shape[1]):
                means[row, o] += k[i] * alpha[i, o]
        variances[row] = min(max(var, 0.0), params[KSS])
    return means, variances
