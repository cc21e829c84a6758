"""Compiled LWPR entry points: learn and predict over the whole model.

Each output dimension has its own set of receptive fields (as in the reference library),
so each output adapts its own distance metric to the inputs that matter for it.
Status codes returned by the learning kernels: 0 done; 1 some output needs a free slot
(the caller grows `rfs` and calls again from the returned row); -(i+1) input i is not
finite; -(n_in+k+1) target k is not finite. Nothing is changed for a rejected sample.
Entry points release the GIL (nogil) so a service's other threads keep running; a model
must still be used from one thread at a time.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from .lwpr_layout import (
    FAST_MATH,
    BETA, BETA0, CENTRE, HP_DIAG_ONLY, HP_EXACT_FIT, LAMBDA, HP_INIT_REG, HP_MAX_RFS, HP_UPDATE_D, HP_W_CUTOFF,
    HP_NOVELTY_SCALE, HP_W_GEN, HP_W_PRUNE, MEAN_X, N_DATA, P_LOAD, SS_S2, SUM_E_CV2, SUM_W, U_DIR,
    mat, rls_inverse, rls_theta, vec,
)
from .lwpr_placement import beyond_experience, init_rf, squared_distance, trace_d
from .lwpr_metric import update_metric
from .lwpr_receptive_field import (
    anneal_lambdas, cross_validated_errors, maybe_add_projection, update_exact_fit,
    update_means, update_projections,
)


@nb.njit(cache=True, fastmath=FAST_MATH)
def update_rf(st, n, n_reg, x, y, w, hp, work):
    """Learn (x, y) with activation w in one receptive field; returns its projection count."""
    xmz, xres, e_cv = work[0:n], work[n:2 * n], work[2 * n:3 * n]
    ok, mdx = work[3 * n:4 * n], work[4 * n:5 * n]
    z, pz = work[5 * n:6 * n + 1], work[6 * n + 1:7 * n + 2]
    lam = vec(st, LAMBDA, n)[0]
    update_means(st, n, x, y, w)
    if hp[HP_EXACT_FIT] != 0.0:
        update_exact_fit(st, n, x, y, w, lam, z, pz)
    mean = vec(st, MEAN_X, n)
    for i in range(n):
        xmz[i] = x[i] - mean[i]
    ymz = y - st[BETA0]
    cross_validated_errors(st, n, n_reg, xmz, ymz, e_cv, xres)
    e = update_projections(st, n, n_reg, xmz, ymz, w, e_cv, xres)
    if hp[HP_UPDATE_D] != 0.0:
        update_metric(st, n, n_reg, x, w, e_cv[n_reg - 1], e, hp[HP_DIAG_ONLY] != 0.0, hp, ok, mdx)
    anneal_lambdas(st, n, n_reg, hp)
    return maybe_add_projection(st, n, n_reg, hp)


@nb.njit(cache=True, fastmath=FAST_MATH)
def update_output(rfs, nreg, n_rfs, k, x, y, hp, work):
    """Update output k's receptive fields; create one where none is active, prune overlaps."""
    n = x.shape[0]
    diag_only = hp[HP_DIAG_ONLY] != 0.0
    # compare squared distances, not activations: exp only for fields that will learn
    q_cut = -2.0 * math.log(hp[HP_W_CUTOFF]) if hp[HP_W_CUTOFF] > 0.0 else math.inf
    q_min, i_max, q_sec, i_sec = math.inf, -1, math.inf, -1
    count = n_rfs[k]
    for j in range(count):
        st = rfs[k, j]
        q = squared_distance(st, n, x, diag_only)
        if q < q_min:
            q_sec, i_sec, q_min, i_max = q_min, i_max, q, j
        elif q < q_sec:
            q_sec, i_sec = q, j
        if q < q_cut:
            nreg[k, j] = update_rf(st, n, nreg[k, j], x, y, math.exp(-0.5 * q), hp, work)
    w_max = math.exp(-0.5 * q_min) if i_max >= 0 else -1.0
    w_sec = math.exp(-0.5 * q_sec) if i_sec >= 0 else -1.0
    if w_max <= hp[HP_W_GEN]:
        if count < rfs.shape[1] and count < hp[HP_MAX_RFS]:
            # the nearest field's adapted metric is the best guess for the new one
            template = rfs[k, i_max] if i_max >= 0 else np.zeros(0)
            st = rfs[k, count]
            init_rf(st, n, x, template, hp)
            nreg[k, count] = update_rf(st, n, min(n, int(hp[HP_INIT_REG])), x, y, 1.0, hp, work)
            n_rfs[k] = count + 1
    elif w_sec > hp[HP_W_PRUNE]:
        # two fields claim the same data: drop the wider one, as the reference library does (one that
        # widened over its neighbour's data averages its detail away)
        victim = i_max if trace_d(rfs[k, i_max], n) < trace_d(rfs[k, i_sec], n) else i_sec
        rfs[k, victim] = rfs[k, count - 1]
        nreg[k, victim] = nreg[k, count - 1]
        n_rfs[k] = count - 1


@nb.njit(cache=True, fastmath=FAST_MATH)
def check_sample(x, y):
    """0 when all finite, else the status code naming the first bad entry."""
    for i in range(x.shape[0]):
        if not math.isfinite(x[i]):
            return -(i + 1)
    for k in range(y.shape[0]):
        if not math.isfinite(y[k]):
            return -(x.shape[0] + k + 1)
    return 0


@nb.njit(cache=True, fastmath=FAST_MATH)
def needs_room(rfs, n_rfs, hp):
    """True when an output may have to create a field but has no free slot yet."""
    for k in range(n_rfs.shape[0]):
        if n_rfs[k] >= rfs.shape[1] and n_rfs[k] < hp[HP_MAX_RFS]:
            return True
    return False


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def learn_one(rfs, nreg, n_rfs, hp, x, y, low, high):
    """Learn (x, y); low and high, the taught range per output, widen to y in place (status 2
    when they did, so the caller refreshes what it derives from them)."""
    status = check_sample(x, y)
    if status != 0:
        return status
    if needs_room(rfs, n_rfs, hp):
        return 1
    work = np.empty(7 * x.shape[0] + 2)
    for k in range(y.shape[0]):
        update_output(rfs, nreg, n_rfs, k, x, y[k], hp, work)
    for k in range(y.shape[0]):
        if y[k] < low[k] or y[k] > high[k]:
            status = 2
            low[k], high[k] = min(low[k], y[k]), max(high[k], y[k])
    return status


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def learn_many(rfs, nreg, n_rfs, hp, xs, ys, start):
    """Learn rows start.. of (xs, ys); returns (status, first row not learned)."""
    work = np.empty(7 * xs.shape[1] + 2)
    for row in range(start, xs.shape[0]):
        status = check_sample(xs[row], ys[row])
        if status != 0:
            return status, row
        if needs_room(rfs, n_rfs, hp):
            return 1, row
        for k in range(ys.shape[1]):
            update_output(rfs, nreg, n_rfs, k, xs[row], ys[row, k], hp, work)
    return 0, xs.shape[0]


@nb.njit(cache=True, fastmath=FAST_MATH)
def rf_prediction(st, n, n_reg, x, xres, exact):
    """The field's local linear prediction and its predictive variance at x."""
    n_data = vec(st, N_DATA, n)
    # a freshly added projection is left out until it has some data behind it
    use = n_reg - 1 if (n_reg > 1 and n_data[n_reg - 1] <= 2 * n) else n_reg
    u, p = mat(st, U_DIR, n), mat(st, P_LOAD, n)
    beta, ss_s2, mean = vec(st, BETA, n), vec(st, SS_S2, n), vec(st, MEAN_X, n)
    sum_w, sum_ecv2 = vec(st, SUM_W, n), vec(st, SUM_E_CV2, n)
    for i in range(n):
        xres[i] = x[i] - mean[i]
    yp = st[BETA0]
    leverage = 1.0 / sum_w[0]
    for r in range(use):
        s = 0.0
        for i in range(n):
            s += u[r * n + i] * xres[i]
        yp += beta[r] * s
        leverage += s * s / ss_s2[r]
        for i in range(n):
            xres[i] -= s * p[r * n + i]
    mse = sum_ecv2[use - 1] / sum_w[use - 1]
    if exact:
        theta, c = rls_theta(st, n), vec(st, CENTRE, n)
        yp = theta[n]
        for i in range(n):
            yp += theta[i] * (x[i] - c[i])
    return yp, mse * (1.0 + leverage)


@nb.njit(cache=True, fastmath=FAST_MATH)
def predict_output(rfs, nreg, n_rfs, k, x, hp, xres):
    """Output k: activation-weighted mean of the fields, support, one-sigma interval.

    A field is trusted once it has learned from 2 n samples (effective, after
    forgetting), as in the reference library; while any trusted field is active, young
    ones are left out, because a field created a moment ago fits its few samples and
    nothing else. Support (the confidence) is the strongest activation, each discounted
    by its field's maturity min(1, samples / 2n), with a novelty scale by how far x lies
    beyond the inputs the field has learned from (lwpr_layout.beyond_experience), and with
    the exact fit by how far x lies off the span of that data (off_span)."""
    n = x.shape[0]
    diag_only, exact = hp[HP_DIAG_ONLY] != 0.0, hp[HP_EXACT_FIT] != 0.0
    novelty_scale = hp[HP_NOVELTY_SCALE]
    q_cut = -2.0 * math.log(hp[HP_W_CUTOFF]) if hp[HP_W_CUTOFF] > 0.0 else math.inf
    trusted_at = 2.0 * n
    sw, swy, swyy, swv = 0.0, 0.0, 0.0, 0.0  # over all active fields
    tw, twy, twyy, twv = 0.0, 0.0, 0.0, 0.0  # over trusted ones
    support = 0.0
    for j in range(n_rfs[k]):
        st = rfs[k, j]
        q = squared_distance(st, n, x, diag_only)
        maturity = min(1.0, vec(st, N_DATA, n)[0] / trusted_at)
        field_support = math.exp(-0.5 * q) * maturity
        if novelty_scale > 0.0 and field_support > support:  # novelty only lowers it: skip the hopeless
            field_support *= math.exp(-0.5 * beyond_experience(st, n, x, novelty_scale))
        if exact and field_support > support:
            field_support *= off_span(st, n, x)
        support = max(support, field_support)
        if q < q_cut:
            w = math.exp(-0.5 * q)
            yp, var = rf_prediction(st, n, nreg[k, j], x, xres, exact)
            sw, swy, swyy, swv = sw + w, swy + w * yp, swyy + w * yp * yp, swv + w * var
            if maturity >= 1.0:
                tw, twy, twyy, twv = tw + w, twy + w * yp, twyy + w * yp * yp, twv + w * var
    if tw > 0.0:
        sw, swy, swyy, swv = tw, twy, twyy, twv
    if sw <= 0.0:
        return 0.0, support, math.inf
    y = swy / sw
    # spread between fields counts as uncertainty too
    spread = max(0.0, swyy / sw - y * y)
    return y, support, math.sqrt(swv / sw + spread)


@nb.njit(cache=True, fastmath=FAST_MATH)
def off_span(st, n, x):
    """1 while x lies within the span of the data the field's exact fit learned from, falling as a
    Gaussian of how far beyond. The fit's leverage z'Pz (z = [x - c, 1]) times its weighted sample
    count is 1 + the squared Mahalanobis distance of x from that data: within it, at most about
    2 (n + 1) (the chi-square 99.9 % point); off its span (two inputs that never parted, a reading
    dragged along) it grows with the fit's prior and the field's guess must not be trusted."""
    c, inverse = vec(st, CENTRE, n), rls_inverse(st, n)
    m = n + 1
    leverage = 0.0
    for i in range(m):
        zi = x[i] - c[i] if i < n else 1.0
        acc = 0.0
        for j in range(m):
            acc += inverse[i * m + j] * (x[j] - c[j] if j < n else 1.0)
        leverage += zi * acc
    distance = math.sqrt(max(leverage * vec(st, SUM_W, n)[0] - 1.0, 0.0))
    beyond = max(distance - math.sqrt(2.0 * m), 0.0)
    return math.exp(-0.5 * beyond * beyond)


@nb.njit(cache=True, fastmath=FAST_MATH)
def calibrated(support, hp):
    """Support mapped so that LWPR's own 'covered' level w_gen reads 0.5.

    LWPR creates a field wherever the strongest activation is below w_gen, i.e. it holds
    such points unsupported; the power keeps the order of activations and puts the
    paper's 'unsure' 0.25 at w_gen^2."""
    w_gen = hp[HP_W_GEN]
    if support <= 0.0 or not 0.0 < w_gen < 1.0:
        return support
    return support ** (math.log(0.5) / math.log(w_gen))


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def predict_many(rfs, nreg, n_rfs, hp, xs):
    """Predictions, confidences and one-sigma intervals for each row of xs.

    Confidence is the strongest activation, taken for the least supported output."""
    n_rows, n_out = xs.shape[0], n_rfs.shape[0]
    ys = np.zeros((n_rows, n_out))
    intervals = np.full((n_rows, n_out), math.inf)
    confidence = np.zeros(n_rows)
    xres = np.empty(xs.shape[1])
    for row in range(n_rows):
        conf = 1.0
        for k in range(n_out):
            y, w_max, interval = predict_output(rfs, nreg, n_rfs, k, xs[row], hp, xres)
            ys[row, k] = y
            intervals[row, k] = interval
            conf = min(conf, w_max)
        confidence[row] = calibrated(conf, hp)
    return ys, confidence, intervals


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def predict_one(rfs, nreg, n_rfs, hp, x, y, intervals, floor, ceiling):
    """Like predict_many for one input, filling the caller's y (held within floor and
    ceiling) and intervals: returning arrays from numba, or clipping with numpy, costs more
    than the prediction. Returns the confidence; -1 for a non-finite input (then nothing is
    computed), -2 when an answer is not finite."""
    for i in range(x.shape[0]):
        if not math.isfinite(x[i]):
            return -1.0
    xres = np.empty(x.shape[0])
    conf = 1.0
    finite = True
    for k in range(n_rfs.shape[0]):
        value, w_max, intervals[k] = predict_output(rfs, nreg, n_rfs, k, x, hp, xres)
        finite = finite and math.isfinite(value)  # before clipping, which could hide a NaN
        y[k] = min(max(value, floor[k]), ceiling[k])
        conf = min(conf, w_max)
    return calibrated(conf, hp) if finite else -2.0

