"""One receptive field's incremental update: weighted means, partial least squares
projections, and the test for adding a projection (Vijayakumar et al. 2005, Table 1-2).

All statistics are exponentially forgotten with a per-projection factor lambda that is
annealed from init_lambda towards final_lambda: early statistics were gathered while the
projection directions were still moving, so they should fade.
"""
from __future__ import annotations

import math

import numba as nb

from .lwpr_layout import (
    FAST_MATH,
    BETA, BETA0, HP_ADD_MIN_DATA, HP_ADD_THRESHOLD, HP_FINAL_LAMBDA, HP_INIT_LAMBDA,
    HP_INIT_S2, HP_MAX_REG, HP_TAU_LAMBDA, LAMBDA, MEAN_X, N_DATA, P_LOAD, S_LAST,
    SS_S2, SS_XRES, SS_XRES_YRES, SS_YRES, SUM_E2, SUM_E_CV2, SUM_W, U_DIR, VAR_X,
    RLS_PRIOR, CENTRE, mat, rls_inverse, rls_theta, vec,
)


@nb.njit(cache=True, fastmath=FAST_MATH)
def update_means(st, n, x, y, w):
    """Forgetting weighted mean and variance of x and mean of y (the RF's offset beta0)."""
    lam = vec(st, LAMBDA, n)[0]
    sum_w = vec(st, SUM_W, n)
    old = lam * sum_w[0]
    new = old + w
    mean, var = vec(st, MEAN_X, n), vec(st, VAR_X, n)
    inv = 1.0 / new
    for i in range(n):
        mean[i] = (old * mean[i] + w * x[i]) * inv
        dx = x[i] - mean[i]
        var[i] = (old * var[i] + w * dx * dx) * inv
    st[BETA0] = (old * st[BETA0] + w * y) * inv


@nb.njit(cache=True, fastmath=FAST_MATH)
def cross_validated_errors(st, n, n_reg, xmz, ymz, e_cv, xres):
    """Errors of the RF's prediction with 1..n_reg projections, before this sample is learned."""
    u, p, beta = mat(st, U_DIR, n), mat(st, P_LOAD, n), vec(st, BETA, n)
    xres[:] = xmz
    yp = 0.0
    for r in range(n_reg):
        s = 0.0
        for i in range(n):
            s += u[r * n + i] * xres[i]
        yp += beta[r] * s
        e_cv[r] = ymz - yp
        for i in range(n):
            xres[i] -= s * p[r * n + i]


@nb.njit(cache=True, fastmath=FAST_MATH)
def update_projections(st, n, n_reg, xmz, ymz, w, e_cv, xres):
    """Incremental PLS: each projection regresses the residual left by the previous ones.

    Returns the final fitting error e (after the update)."""
    u, p = mat(st, U_DIR, n), mat(st, P_LOAD, n)
    sxy, sxx = mat(st, SS_XRES_YRES, n), mat(st, SS_XRES, n)
    beta, ss_s2, ss_y = vec(st, BETA, n), vec(st, SS_S2, n), vec(st, SS_YRES, n)
    lam_v, sum_w, n_data = vec(st, LAMBDA, n), vec(st, SUM_W, n), vec(st, N_DATA, n)
    sum_ecv2, s_last = vec(st, SUM_E_CV2, n), vec(st, S_LAST, n)
    xres[:] = xmz
    yres = ymz
    lam0 = lam_v[0]
    for r in range(n_reg):
        lam = lam_v[r]
        row = r * n
        norm = 0.0
        dot = 0.0  # sxy . xres, so s needs no second pass over the new direction
        for i in range(n):
            value = lam * sxy[row + i] + w * yres * xres[i]
            sxy[row + i] = value
            norm += value * value
            dot += value * xres[i]
        if norm > 0.0:
            inv = 1.0 / math.sqrt(norm)
            for i in range(n):
                u[row + i] = sxy[row + i] * inv
            s = dot * inv
        else:
            s = 0.0
            for i in range(n):
                s += u[row + i] * xres[i]
        ss_s2[r] = lam * ss_s2[r] + w * s * s
        ss_y[r] = lam * ss_y[r] + w * yres * s
        inv_ss = 1.0 / ss_s2[r]
        beta[r] = ss_y[r] * inv_ss
        for i in range(n):
            value = lam * sxx[row + i] + w * xres[i] * s
            sxx[row + i] = value
            p[row + i] = value * inv_ss
            xres[i] -= s * p[row + i]
        yres -= s * beta[r]
        s_last[r] = s
        sum_ecv2[r] = lam * sum_ecv2[r] + w * e_cv[r] * e_cv[r]
        sum_w[r] = lam * sum_w[r] + w
        n_data[r] = lam * n_data[r] + 1.0
    st[SUM_E2] = lam0 * st[SUM_E2] + w * yres * yres
    return yres


@nb.njit(cache=True, fastmath=FAST_MATH)
def anneal_lambdas(st, n, n_reg, hp):
    """Move each projection's forgetting factor towards final_lambda."""
    lam = vec(st, LAMBDA, n)
    tau, final = hp[HP_TAU_LAMBDA], hp[HP_FINAL_LAMBDA]
    for r in range(n_reg):
        lam[r] = tau * lam[r] + final * (1.0 - tau)


@nb.njit(cache=True, fastmath=FAST_MATH)
def maybe_add_projection(st, n, n_reg, hp):
    """Add a projection once the newest one has enough data and still pays off.

    The newest projection 'pays off' when its cross-validated error is below
    add_threshold times the previous one's. 'Enough data' is a count (add_min_data), not
    the reference library's n_data*(1-lambda) > 0.5, which waits ~500 samples per
    projection and is why it needs minutes for the mirroring task. Returns the new count."""
    max_reg = min(n, int(hp[HP_MAX_REG]))
    if n_reg >= max_reg or n_reg < 2:
        return n_reg
    sum_ecv2, sum_w, n_data = vec(st, SUM_E_CV2, n), vec(st, SUM_W, n), vec(st, N_DATA, n)
    last = n_reg - 1
    mse_last = sum_ecv2[last] / sum_w[last] + 1e-10
    mse_prev = sum_ecv2[last - 1] / sum_w[last - 1] + 1e-10
    enough = n_data[last] > hp[HP_ADD_MIN_DATA]
    if not (enough and mse_last < hp[HP_ADD_THRESHOLD] * mse_prev):
        return n_reg
    vec(st, LAMBDA, n)[n_reg] = hp[HP_INIT_LAMBDA]
    vec(st, SS_S2, n)[n_reg] = hp[HP_INIT_S2]
    vec(st, SUM_W, n)[n_reg] = 1e-10
    vec(st, N_DATA, n)[n_reg] = 1e-10
    return n_reg + 1


@nb.njit(cache=True, fastmath=FAST_MATH)
def update_exact_fit(st, n, x, y, w, lam, z, pz):
    """Weighted recursive least squares of y on z = [x - c, 1], forgetting like the projections.

    Incremental PLS converges slowly when many inputs are irrelevant, because early
    statistics were gathered along directions that later moved; the exact fit needs
    only n + 1 well-spread samples, which is what a few seconds of demonstration give."""
    c, theta, inverse = vec(st, CENTRE, n), rls_theta(st, n), rls_inverse(st, n)
    m = n + 1
    for i in range(n):
        z[i] = x[i] - c[i]
    z[n] = 1.0
    err = y
    for i in range(m):
        err -= theta[i] * z[i]
    spread = inverse_times(inverse, m, z, pz)
    if spread <= 0.0:
        # rounding has cost the inverse its positive definiteness (z'Pz <= 0): start it
        # again from the prior; the coefficients keep what they learned
        inverse[:] = 0.0
        for i in range(m):
            inverse[i * m + i] = RLS_PRIOR
        spread = inverse_times(inverse, m, z, pz)
    root, inv_lam = math.sqrt(1.0 / (lam / w + spread)), 1.0 / lam
    for i in range(m):
        pz[i] *= root  # now a = P z / sqrt(denom): the update is a a', symmetric bit for bit
    trace = 0.0
    for i in range(m):
        theta[i] += pz[i] * root * err
        a_i = pz[i]
        row = i * m
        for j in range(m):  # whole rows: they vectorise
            inverse[row + j] = (inverse[row + j] - a_i * pz[j]) * inv_lam
        trace += inverse[row + i]
    if trace > m * RLS_PRIOR:  # inputs that never vary would otherwise wind the inverse up
        scale = m * RLS_PRIOR / trace
        for i in range(m * m):
            inverse[i] *= scale


@nb.njit(cache=True, fastmath=FAST_MATH)
def inverse_times(inverse, m, z, pz):
    """pz = P z for the row-major m-square P; returns z'P z."""
    spread = 0.0
    for i in range(m):
        acc = 0.0
        row = i * m
        for j in range(m):
            acc += inverse[row + j] * z[j]
        pz[i] = acc
        spread += z[i] * acc
    return spread
