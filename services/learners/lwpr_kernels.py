"""Compiled LWPR entry points: learn and predict over the whole model (lwpr_model.LWPRModel).

Each output dimension has its own list of receptive fields (as in the reference library),
so each output adapts its own distance metric to the inputs that matter for it.
Status codes returned by the learning kernels: 0 done; -(i+1) input i is not finite;
-(n_in+k+1) target k is not finite (nothing is changed for a rejected sample); learn_one adds
TAUGHT_WIDENED and SHOWN_WIDENED when it widened the taught outputs' or the shown inputs' range.
Entry points release the GIL (nogil) so a service's other threads keep running; a model
must still be used from one thread at a time.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from .base import within
from .lwpr_model import FAST_MATH
from .lwpr_placement import beyond_experience, inherit_metric, new_field, squared_distance, trace_d
from .lwpr_metric import update_metric
from .lwpr_receptive_field import (
    anneal_lambdas, cross_validated_errors, maybe_add_projection, update_exact_fit,
    update_means, update_projections,
)

TAUGHT_WIDENED, SHOWN_WIDENED = 1, 2


@nb.njit(cache=True, fastmath=FAST_MATH)
def update_rf(rf, x, y, w, model, work):
    """Learn (x, y) with activation w in one receptive field (Vijayakumar et al. 2005, Table 1)."""
    n = x.shape[0]
    xmz, xres, e_cv = work[0:n], work[n:2 * n], work[2 * n:3 * n]
    ok, mdx = work[3 * n:4 * n], work[4 * n:5 * n]
    z, pz = work[5 * n:6 * n + 1], work[6 * n + 1:7 * n + 2]
    lam = rf.lam[0]
    update_means(rf, x, y, w)
    if model.exact_fit:
        update_exact_fit(rf, x, y, w, lam, z, pz)
    mean = rf.mean_x
    for i in range(n):
        xmz[i] = x[i] - mean[i]
    ymz = y - rf.beta0
    cross_validated_errors(rf, xmz, ymz, e_cv, xres)
    e = update_projections(rf, xmz, ymz, w, e_cv, xres)
    if model.update_d:
        update_metric(rf, x, w, e_cv[rf.n_reg - 1], e, model, ok, mdx)
    anneal_lambdas(rf, model)
    maybe_add_projection(rf, model)


@nb.njit(cache=True, fastmath=FAST_MATH)
def update_output(model, k, x, y, work):
    """Update output k's receptive fields; create one where none is active, prune overlaps."""
    fields = model.outputs[k]
    # compare squared distances, not activations: exp only for fields that will learn
    q_cut = -2.0 * math.log(model.w_cutoff) if model.w_cutoff > 0.0 else math.inf
    q_min, i_max, q_sec, i_sec = math.inf, -1, math.inf, -1
    count = len(fields)
    for j in range(count):
        rf = fields[j]
        q = squared_distance(rf, x, model.diag_only)
        if q < q_min:
            q_sec, i_sec, q_min, i_max = q_min, i_max, q, j
        elif q < q_sec:
            q_sec, i_sec = q, j
        if q < q_cut:
            update_rf(rf, x, y, math.exp(-0.5 * q), model, work)
    w_max = math.exp(-0.5 * q_min) if i_max >= 0 else -1.0
    w_sec = math.exp(-0.5 * q_sec) if i_sec >= 0 else -1.0
    if w_max <= model.w_gen:
        if count < model.max_rfs:
            rf = new_field(model, x)
            if i_max >= 0:
                inherit_metric(rf, fields[i_max])
            rf.n_reg = min(x.shape[0], model.init_reg)
            update_rf(rf, x, y, 1.0, model, work)
            fields.append(rf)
    elif w_sec > model.w_prune:
        # two fields claim the same data: drop the wider one, as the reference library does (one that
        # widened over its neighbour's data averages its detail away); the last field takes its place
        victim = i_max if trace_d(fields[i_max]) < trace_d(fields[i_sec]) else i_sec
        fields[victim] = fields[count - 1]
        fields.pop()


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
def widen(values, low, high):
    """Widen the range [low, high] in place to take in `values`; True when it had to."""
    widened = False
    for i in range(values.shape[0]):
        if values[i] < low[i] or values[i] > high[i]:
            widened = True
            low[i], high[i] = min(low[i], values[i]), max(high[i], values[i])
    return widened


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def learn_one(model, x, y, raw, taught_low, taught_high, shown_low, shown_high):
    """Learn (x, y), x the input as the model takes it (raw divided by norm_in). The learner's taught
    range of the outputs widens to y in place, its shown range of the inputs to raw (the status says
    which did, so the caller refreshes what it derives from them): numpy would cost more than the update."""
    status = check_sample(x, y)
    if status != 0:
        return status
    work = np.empty(7 * x.shape[0] + 2)
    for k in range(y.shape[0]):
        update_output(model, k, x, y[k], work)
    if widen(y, taught_low, taught_high):
        status += TAUGHT_WIDENED
    if widen(raw, shown_low, shown_high):
        status += SHOWN_WIDENED
    return status


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def learn_many(model, xs, ys):
    """Learn the rows of (xs, ys) in order up to a refused one; returns (status, rows learned)."""
    work = np.empty(7 * xs.shape[1] + 2)
    for row in range(xs.shape[0]):
        status = check_sample(xs[row], ys[row])
        if status != 0:
            return status, row
        for k in range(ys.shape[1]):
            update_output(model, k, xs[row], ys[row, k], work)
    return 0, xs.shape[0]


@nb.njit(cache=True, fastmath=FAST_MATH)
def rf_prediction(rf, x, xres, exact):
    """The field's local linear prediction and its predictive variance at x."""
    n, n_reg, n_data = x.shape[0], rf.n_reg, rf.n_data
    # a freshly added projection is left out until it has some data behind it
    use = n_reg - 1 if (n_reg > 1 and n_data[n_reg - 1] <= 2 * n) else n_reg
    u, p, beta, ss_s2, mean = rf.U, rf.P, rf.beta, rf.ss_s2, rf.mean_x
    sum_w, sum_ecv2 = rf.sum_w, rf.sum_e_cv2
    for i in range(n):
        xres[i] = x[i] - mean[i]
    yp = rf.beta0
    leverage = 1.0 / sum_w[0]
    for r in range(use):
        s = 0.0
        for i in range(n):
            s += u[r, i] * xres[i]
        yp += beta[r] * s
        leverage += s * s / ss_s2[r]
        for i in range(n):
            xres[i] -= s * p[r, i]
    mse = sum_ecv2[use - 1] / sum_w[use - 1]
    if exact:
        theta, c = rf.rls_theta, rf.centre
        yp = theta[n]
        for i in range(n):
            yp += theta[i] * (x[i] - c[i])
    return yp, mse * (1.0 + leverage)


@nb.njit(cache=True, fastmath=FAST_MATH)
def predict_output(model, k, x, xres):
    """Output k: activation-weighted mean of the fields, support, one-sigma interval.

    A field is trusted once it has learned from 2 n samples (effective, after
    forgetting), as in the reference library; while any trusted field is active, young
    ones are left out, because a field created a moment ago fits its few samples and
    nothing else. Support (the confidence) is the strongest activation, each discounted
    by its field's maturity min(1, samples / 2n), with a novelty scale by how far x lies
    beyond the inputs the field has learned from (lwpr_placement.beyond_experience), and with
    the exact fit by how far x lies off the span of that data (off_span)."""
    n = x.shape[0]
    diag_only, exact, novelty_scale = model.diag_only, model.exact_fit, model.novelty_scale
    q_cut = -2.0 * math.log(model.w_cutoff) if model.w_cutoff > 0.0 else math.inf
    trusted_at = 2.0 * n
    sw, swy, swyy, swv = 0.0, 0.0, 0.0, 0.0  # over all active fields
    tw, twy, twyy, twv = 0.0, 0.0, 0.0, 0.0  # over trusted ones
    support = 0.0
    for rf in model.outputs[k]:
        q = squared_distance(rf, x, diag_only)
        maturity = min(1.0, rf.n_data[0] / trusted_at)
        field_support = math.exp(-0.5 * q) * maturity
        if novelty_scale > 0.0 and field_support > support:  # novelty only lowers it: skip the hopeless
            field_support *= math.exp(-0.5 * beyond_experience(rf, x, novelty_scale))
        if exact and field_support > support:
            field_support *= off_span(rf, x)
        support = max(support, field_support)
        if q < q_cut:
            w = math.exp(-0.5 * q)
            yp, var = rf_prediction(rf, x, xres, exact)
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
def off_span(rf, x):
    """1 while x lies within the span of the data the field's exact fit learned from, falling as a
    Gaussian of how far beyond. The fit's leverage z'Pz (z = [x - c, 1]) times its weighted sample
    count is 1 + the squared Mahalanobis distance of x from that data: within it, at most about
    2 (n + 1) (the chi-square 99.9 % point); off its span (two inputs that never parted, a reading
    dragged along) it grows with the fit's prior and the field's guess must not be trusted."""
    c, inverse = rf.centre, rf.rls_inverse
    n = x.shape[0]
    m = n + 1
    leverage = 0.0
    for i in range(m):
        zi = x[i] - c[i] if i < n else 1.0
        acc = 0.0
        for j in range(m):
            acc += inverse[i, j] * (x[j] - c[j] if j < n else 1.0)
        leverage += zi * acc
    distance = math.sqrt(max(leverage * rf.sum_w[0] - 1.0, 0.0))
    beyond = max(distance - math.sqrt(2.0 * m), 0.0)
    return math.exp(-0.5 * beyond * beyond)


@nb.njit(cache=True, fastmath=FAST_MATH)
def calibrated(support, w_gen):
    """Support mapped so that LWPR's own 'covered' level w_gen reads 0.5.

    LWPR creates a field wherever the strongest activation is below w_gen, i.e. it holds
    such points unsupported; the power keeps the order of activations and puts the
    paper's 'unsure' 0.25 at w_gen^2."""
    if support <= 0.0 or not 0.0 < w_gen < 1.0:
        return support
    return support ** (math.log(0.5) / math.log(w_gen))


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def predict_many(model, xs):
    """Predictions, confidences and one-sigma intervals for each row of xs.

    Confidence is the strongest activation, taken for the least supported output."""
    n_rows, n_out = xs.shape[0], len(model.outputs)
    ys = np.zeros((n_rows, n_out))
    intervals = np.full((n_rows, n_out), math.inf)
    confidence = np.zeros(n_rows)
    xres = np.empty(xs.shape[1])
    for row in range(n_rows):
        conf = 1.0
        for k in range(n_out):
            y, w_max, interval = predict_output(model, k, xs[row], xres)
            ys[row, k] = y
            intervals[row, k] = interval
            conf = min(conf, w_max)
        confidence[row] = calibrated(conf, model.w_gen)
    return ys, confidence, intervals


@nb.njit(cache=True, fastmath=FAST_MATH, nogil=True)
def predict_one(model, x, y, intervals, floor, ceiling, raw, shown_low, shown_high):
    """Like predict_many for one input, filling the caller's y (held within floor and
    ceiling) and intervals: returning arrays from numba, or clipping with numpy, costs more
    than the prediction. Returns the confidence (-1 for a non-finite input, then nothing is
    computed; -2 when an answer is not finite) and whether raw lies beyond the inputs shown."""
    beyond = not within(raw, shown_low, shown_high)
    for i in range(x.shape[0]):
        if not math.isfinite(x[i]):
            return -1.0, beyond
    xres = np.empty(x.shape[0])
    conf = 1.0
    finite = True
    for k in range(len(model.outputs)):
        value, w_max, intervals[k] = predict_output(model, k, x, xres)
        finite = finite and math.isfinite(value)  # before clipping, which could hide a NaN
        y[k] = min(max(value, floor[k]), ceiling[k])
        conf = min(conf, w_max)
    return (calibrated(conf, model.w_gen) if finite else -2.0), beyond


@nb.njit(cache=True)
def field_counts(model):
    """How many receptive fields each output has."""
    counts = np.zeros(len(model.outputs), dtype=np.int64)
    for k in range(len(model.outputs)):
        counts[k] = len(model.outputs[k])
    return counts


@nb.njit(cache=True)
def sharpest_metric(model):
    """Per input, the largest D_ii of any field (0 with none): the narrowest width is 1 / sqrt of it."""
    sharpest = np.zeros(model.n_in)
    for fields in model.outputs:
        for rf in fields:
            for i in range(model.n_in):
                sharpest[i] = max(sharpest[i], rf.D[i, i])
    return sharpest
