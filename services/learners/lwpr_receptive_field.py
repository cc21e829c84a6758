"""One receptive field's incremental update: weighted means, partial least squares
projections, and the test for adding a projection (Vijayakumar et al. 2005, Table 1-2).

All statistics are exponentially forgotten with a per-projection factor lambda that is
annealed from init_lambda towards final_lambda: early statistics were gathered while the
projection directions were still moving, so they should fade.
"""
from __future__ import annotations

import math

import numba as nb

from .lwpr_model import FAST_MATH, RLS_PRIOR


@nb.njit(cache=True, fastmath=FAST_MATH)
def update_means(rf, x, y, w):
    """Forgetting weighted mean and variance of x and mean of y (the RF's offset beta0)."""
    lam = rf.lam[0]
    old = lam * rf.sum_w[0]
    new = old + w
    mean, var = rf.mean_x, rf.var_x
    inv = 1.0 / new
    for i in range(x.shape[0]):
        mean[i] = (old * mean[i] + w * x[i]) * inv
        dx = x[i] - mean[i]
        var[i] = (old * var[i] + w * dx * dx) * inv
    rf.beta0 = (old * rf.beta0 + w * y) * inv


@nb.njit(cache=True, fastmath=FAST_MATH)
def cross_validated_errors(rf, xmz, ymz, e_cv, xres):
    """Errors of the RF's prediction with 1..n_reg projections, before this sample is learned."""
    u, p, beta = rf.U, rf.P, rf.beta
    n = xmz.shape[0]
    for i in range(n):
        xres[i] = xmz[i]
    yp = 0.0
    for r in range(rf.n_reg):
        s = 0.0
        for i in range(n):
            s += u[r, i] * xres[i]
        yp += beta[r] * s
        e_cv[r] = ymz - yp
        for i in range(n):
            xres[i] -= s * p[r, i]


@nb.njit(cache=True, fastmath=FAST_MATH)
def update_projections(rf, xmz, ymz, w, e_cv, xres):
    """Incremental PLS: each projection regresses the residual left by the previous ones.

    Returns the final fitting error e (after the update)."""
    u, p, sxy, sxx = rf.U, rf.P, rf.ss_xres_yres, rf.ss_xres
    beta, ss_s2, ss_y = rf.beta, rf.ss_s2, rf.ss_yres
    lam_v, sum_w, n_data = rf.lam, rf.sum_w, rf.n_data
    sum_ecv2, s_last = rf.sum_e_cv2, rf.s_last
    n = xmz.shape[0]
    for i in range(n):
        xres[i] = xmz[i]
    yres = ymz
    lam0 = lam_v[0]
    for r in range(rf.n_reg):
        lam = lam_v[r]
        norm = 0.0
        dot = 0.0  # sxy . xres, so s needs no second pass over the new direction
        for i in range(n):
            value = lam * sxy[r, i] + w * yres * xres[i]
            sxy[r, i] = value
            norm += value * value
            dot += value * xres[i]
        if norm > 0.0:
            inv = 1.0 / math.sqrt(norm)
            for i in range(n):
                u[r, i] = sxy[r, i] * inv
            s = dot * inv
        else:
            s = 0.0
            for i in range(n):
                s += u[r, i] * xres[i]
        ss_s2[r] = lam * ss_s2[r] + w * s * s
        ss_y[r] = lam * ss_y[r] + w * yres * s
        inv_ss = 1.0 / ss_s2[r]
        beta[r] = ss_y[r] * inv_ss
        for i in range(n):
            value = lam * sxx[r, i] + w * xres[i] * s
            sxx[r, i] = value
            p[r, i] = value * inv_ss
            xres[i] -= s * p[r, i]
        yres -= s * beta[r]
        s_last[r] = s
        sum_ecv2[r] = lam * sum_ecv2[r] + w * e_cv[r] * e_cv[r]
        sum_w[r] = lam * sum_w[r] + w
        n_data[r] = lam * n_data[r] + 1.0
    rf.sum_e2 = lam0 * rf.sum_e2 + w * yres * yres
    return yres


@nb.njit(cache=True, fastmath=FAST_MATH)
def anneal_lambdas(rf, model):
    """Move each projection's forgetting factor towards final_lambda."""
    lam = rf.lam
    tau, final = model.tau_lambda, model.final_lambda
    for r in range(rf.n_reg):
        lam[r] = tau * lam[r] + final * (1.0 - tau)


@nb.njit(cache=True, fastmath=FAST_MATH)
def maybe_add_projection(rf, model):
    """Add a projection once the newest one has enough data and still pays off.

    The newest projection 'pays off' when its cross-validated error is below
    add_threshold times the previous one's. 'Enough data' is a count (add_min_data), not
    the reference library's n_data*(1-lambda) > 0.5, which waits ~500 samples per
    projection and is why it needs minutes for the mirroring task."""
    n_reg = rf.n_reg
    max_reg = min(rf.centre.shape[0], model.max_reg)
    if n_reg >= max_reg or n_reg < 2:
        return
    sum_ecv2, sum_w, n_data = rf.sum_e_cv2, rf.sum_w, rf.n_data
    last = n_reg - 1
    mse_last = sum_ecv2[last] / sum_w[last] + 1e-10
    mse_prev = sum_ecv2[last - 1] / sum_w[last - 1] + 1e-10
    enough = n_data[last] > model.add_min_data
    if not (enough and mse_last < model.add_threshold * mse_prev):
        return
    rf.lam[n_reg] = model.init_lambda
    rf.ss_s2[n_reg] = model.init_s2
    rf.sum_w[n_reg] = 1e-10
    rf.n_data[n_reg] = 1e-10
    rf.n_reg = n_reg + 1


@nb.njit(cache=True, fastmath=FAST_MATH)
def update_exact_fit(rf, x, y, w, lam, z, pz):
    """Weighted recursive least squares of y on z = [x - c, 1], forgetting like the projections.

    Incremental PLS converges slowly when many inputs are irrelevant, because early
    statistics were gathered along directions that later moved; the exact fit needs
    only n + 1 well-spread samples, which is what a few seconds of demonstration give."""
    c, theta, inverse = rf.centre, rf.rls_theta, rf.rls_inverse
    n = x.shape[0]
    m = n + 1
    for i in range(n):
        z[i] = x[i] - c[i]
    z[n] = 1.0
    err = y
    for i in range(m):
        err -= theta[i] * z[i]
    spread = inverse_times(inverse, z, pz)
    if spread <= 0.0:
        # rounding has cost the inverse its positive definiteness (z'Pz <= 0): start it
        # again from the prior; the coefficients keep what they learned
        inverse[:] = 0.0
        for i in range(m):
            inverse[i, i] = RLS_PRIOR
        spread = inverse_times(inverse, z, pz)
    root, inv_lam = math.sqrt(1.0 / (lam / w + spread)), 1.0 / lam
    for i in range(m):
        pz[i] *= root  # now a = P z / sqrt(denom): the update is a a', symmetric bit for bit
    trace = 0.0
    for i in range(m):
        theta[i] += pz[i] * root * err
        a_i = pz[i]
        for j in range(m):  # whole rows: they vectorise
            inverse[i, j] = (inverse[i, j] - a_i * pz[j]) * inv_lam
        trace += inverse[i, i]
    if trace > m * RLS_PRIOR:  # inputs that never vary would otherwise wind the inverse up
        scale = m * RLS_PRIOR / trace
        for i in range(m):
            for j in range(m):
                inverse[i, j] *= scale


@nb.njit(cache=True, fastmath=FAST_MATH)
def inverse_times(inverse, z, pz):
    """pz = P z for the m-square P; returns z'P z."""
    m = inverse.shape[0]
    spread = 0.0
    for i in range(m):
        acc = 0.0
        for j in range(m):
            acc += inverse[i, j] * z[j]
        pz[i] = acc
        spread += z[i] * acc
    return spread
