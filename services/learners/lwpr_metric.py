"""Distance-metric adaptation: gradient descent on the RF's leave-one-out cost
(Vijayakumar et al. 2005, section 3.2 and appendix), with optional meta-learning of the
per-entry learning rates (incremental delta-bar-delta, Sutton 1992).

D = M'M with M upper triangular keeps D positive definite whatever the step. The cost
J = (1/W) sum w e_cv^2 + (penalty/n) sum D_ij^2 is minimised through its incremental
approximation: dJ/dM = dJ1/dw dw/dM + (w/W) dJ2/dM.
"""
from __future__ import annotations

import math

import numba as nb

from .lwpr_model import FAST_MATH

E10, E_MINUS10 = math.exp(10.0), math.exp(-10.0)  # bounds of the meta rates, as exp(+-10)


@nb.njit(cache=True, fastmath=FAST_MATH)
def trusted_projections(rf, ok):
    """A projection's statistics enter the gradient once it has seen 0.1/(1-lambda) samples."""
    lam, n_data = rf.lam, rf.n_data
    for r in range(rf.n_reg):
        ok[r] = 1.0 if n_data[r] > 0.1 / (1.0 - lam[r]) else 0.0


@nb.njit(cache=True, fastmath=FAST_MATH)
def cost_derivatives_in_w(rf, w, e_cv, e, ok, meta):
    """dJ1/dw, its second derivative (only for meta-learning), the hat value h and the damping."""
    s, ss_s2 = rf.s_last, rf.ss_s2
    h_tr, r_tr = rf.h_trace, rf.r_trace
    n_reg = rf.n_reg
    inv_w = 1.0 / rf.sum_w[0]
    big_e = rf.sum_e_cv2[n_reg - 1]
    # damping while the fit is still far worse in cross-validation than in training
    transient = min(1.0, (rf.sum_e2 / (big_e + 1e-10)) ** 4)
    h = 0.0
    h_pse = 0.0
    r_ps2 = 0.0
    s_pse = 0.0
    for r in range(n_reg):
        if ok[r]:
            ps = s[r] / ss_s2[r]
            h += w * s[r] * ps
            h_pse += ps * e * h_tr[r]
            r_ps2 += ps * ps * r_tr[r]
            s_pse += s[r] * ps * e
    e_cv2 = e_cv * e_cv
    dj1dw = (-big_e * inv_w + e_cv2 - 2.0 * h_pse - 2.0 * r_ps2) * inv_w
    if not meta:
        return dj1dw, 0.0, h, transient
    d2 = 0.0
    for r in range(n_reg):
        if ok[r]:
            ps = s[r] / ss_s2[r]
            d2 += (-ps * e * inv_w - 2.0 * ps * s_pse) * h_tr[r]
    d2j1dw2 = (inv_w * (-2.0 * d2 + 2.0 * e * e * h / max(w, 1e-300))
               + inv_w * inv_w * (-2.0 * e_cv2 + 2.0 * h_pse + big_e * inv_w))
    return dj1dw, d2j1dw2, h, transient


@nb.njit(cache=True, fastmath=FAST_MATH)
def update_metric(rf, x, w, e_cv, e, model, ok, mdx):
    """One gradient step on M (and on the learning rates when meta is on)."""
    trusted_projections(rf, ok)
    if not ok[0]:
        return
    meta, diag_only = model.meta, model.diag_only
    dj1dw, d2j1dw2, h, transient = cost_derivatives_in_w(rf, w, e_cv, e, ok, meta)
    w_over_big_w = w / rf.sum_w[0]
    n = x.shape[0]
    penalty = model.penalty / n
    c, m, d, alpha = rf.centre, rf.M, rf.D, rf.alpha
    b, hm = rf.meta_b, rf.meta_h
    max_m = 0.0
    for r in range(n):  # (M dx)_r, with M upper triangular
        acc = 0.0
        for col in range(r, r + 1 if diag_only else n):
            acc += m[r, col] * (x[col] - c[col])
            max_m = max(max_m, abs(m[r, col]))
        mdx[r] = acc
    dwdq, d2wdq2 = -0.5 * w, 0.25 * w  # Gaussian kernel w = exp(-q/2)
    for r in range(n):
        end = r + 1 if diag_only else n  # a diagonal M has nothing right of its diagonal
        row_m2 = 0.0
        for k in range(r, end):
            row_m2 += m[r, k] * m[r, k]
        for col in range(r, end):
            dxl = x[col] - c[col]
            md = 0.0  # (M D)_rl
            for k in range(r, end):
                md += m[r, k] * d[k, col]
            dqdm = 2.0 * mdx[r] * dxl
            dwdm = dwdq * dqdm
            djdm = dwdm * dj1dw + w_over_big_w * 4.0 * penalty * md
            if meta:
                d2wdm2 = d2wdq2 * dqdm * dqdm + dwdq * 2.0 * dxl * dxl
                d2j2 = 2.0 * penalty * (2.0 * row_m2 + 2.0 * m[r, col] ** 2 + 2.0 * d[col, col])
                d2jdm2 = d2wdm2 * dj1dw + dwdm * dwdm * d2j1dw2 + w_over_big_w * d2j2
                meta_step(r, col, b, alpha, hm, djdm, d2jdm2, transient, model.meta_rate)
            delta = alpha[r, col] * djdm * transient
            if delta > 0.1 * max_m:  # a step that would shrink M this much is a bad sign
                alpha[r, col] *= 0.5
                delta = 0.0
            m[r, col] -= delta
    rebuild_d(m, d, diag_only)
    update_traces(rf, w, e_cv, h, transient, ok)


@nb.njit(cache=True, fastmath=FAST_MATH, inline="always")
def meta_step(r, col, b, alpha, hm, djdm, d2jdm2, transient, meta_rate):
    """Incremental delta-bar-delta on entry (r, col)'s learning rate (and its memory trace)."""
    step = min(0.1, max(-0.1, meta_rate * transient * djdm * hm[r, col]))
    # b holds exp(meta log-rate): exp(b - step) = b * exp(-step), and a cubic gives
    # exp(-step) to 5e-6 for |step| <= 0.1 without an exp per entry
    b[r, col] = min(E10, max(E_MINUS10, b[r, col] * (1.0 - step * (1.0 - step * (0.5 - step / 6.0)))))
    alpha[r, col] = b[r, col]  # as in the reference, this also undoes any earlier halving
    hm[r, col] = hm[r, col] * max(0.0, 1.0 - alpha[r, col] * d2jdm2 * transient) - alpha[r, col] * djdm * transient


@nb.njit(cache=True, fastmath=FAST_MATH)
def rebuild_d(m, d, diag_only):
    """D = M'M."""
    n = m.shape[0]
    if diag_only:
        for i in range(n):
            d[i, i] = m[i, i] ** 2
        return
    for i in range(n):
        for j in range(i, n):
            acc = 0.0
            for k in range(min(i, j) + 1):
                acc += m[k, i] * m[k, j]
            d[i, j] = acc
            d[j, i] = acc


@nb.njit(cache=True, fastmath=FAST_MATH)
def update_traces(rf, w, e_cv, h, transient, ok):
    """The H and R memory traces of the incremental leave-one-out gradient."""
    if h >= 1.0:
        return
    s, lam = rf.s_last, rf.lam
    h_tr, r_tr = rf.h_trace, rf.r_trace
    for r in range(rf.n_reg):
        if ok[r]:
            h_tr[r] = lam[r] * h_tr[r] + w / (1.0 - h) * s[r] * e_cv * transient
            r_tr[r] = lam[r] * r_tr[r] + w * w * e_cv * e_cv / (1.0 - h) * s[r] ** 2 * transient
