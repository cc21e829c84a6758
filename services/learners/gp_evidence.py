"""Which inputs matter, and how much the outputs vary: the GP's hyper-parameters by maximum a
posteriori evidence (Rasmussen & Williams 2006, ch. 5), on normalised data.

The kernel is a squared exponential with one length scale per input (automatic relevance
determination): an input whose length scale grows long stops mattering, so distractors that move
while the robot is taught are learned to be ignored. Priors keep a fit on few, correlated samples
sane: length scales log-normal around sqrt(n) (the width at which every input counts a little),
and the signal's amplitude log-normal around the spread of the taught outputs, so that where the
learner has seen nothing its doubt is as large as what it has seen (a fit left free shrinks the
amplitude on smooth streams and the robot would drive on, sure of itself, where it knows nothing).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dpotrf, dtrtrs
from scipy.optimize import minimize

LOG_ELL_BOUNDS = (-3.0, 6.0)  # length scales from 0.05 to 400 input standard deviations
LOG_SF_BOUNDS = (-2.0, 2.0)
# length scales' prior median, in log units beyond sqrt(n) (the width at which every input counts a
# little): an input matters once the teaching shows it does, so a few samples in which the legs moved
# along one line do not make the robot doubt whether its legs matter to its head
SPARSITY = 2.0
AMPLITUDE_PRIOR_SD = 0.1  # of log amplitude, around the taught outputs' spread
SHARE_PRIOR_SD = 3.0  # of the linear share's logit, around a half
LOGIT_SHARE_BOUNDS = (-12.0, 12.0)
# an input whose spread is under this share of the median input's has not varied: a joint that only
# jittered while the robot was taught (a head held still, 1e-7 rad) tells nothing of how much it matters,
# and normalised by that spread any length scale is microscopic, so that moving it later (the head taught
# next) would throw every answer off; such an input keeps the prior's length scale, as one that never moved
JITTER_SHARE = 1e-3


@dataclass(frozen=True)
class Evidence:
    """A fit in normalised units: log length scales (per varying input), log amplitude, log noise,
    and the linear part's share of the prior variance as a logit."""

    log_ell: np.ndarray
    log_sf: float
    log_sn: float
    logit_linear: float
    source_log_sn: np.ndarray | None = None  # fitted by source: the log noise of sources 1 to g - 1 (0's: log_sn)

    def theta(self) -> np.ndarray:
        more = () if self.source_log_sn is None else (self.source_log_sn,)
        return np.concatenate([self.log_ell, [self.log_sf, self.log_sn, self.logit_linear], *more])


def kernel_shapes(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The unit squared exponential and the linear part z z' on centred, relevance-scaled inputs. Both
    symmetric to the bit: numpy multiplies z by its own transpose as one symmetric product (BLAS's syrk)."""
    sq = (z * z).sum(1)
    gram = z @ z.T
    smooth = sq[:, None] + sq[None, :]  # then in place, each step as exp(-0.5 max(sq + sq' - 2 gram, 0)) takes it
    smooth -= 2.0 * gram
    np.maximum(smooth, 0.0, out=smooth)
    smooth *= -0.5
    return np.exp(smooth, out=smooth), gram


def factor_and_invert(gram: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The lower Cholesky factor of a Fortran-ordered gram (factored in place) and the gram's inverse; None
    when it is not positive definite. LAPACK directly: to the bit what scipy's cholesky and solve_triangular
    give (numpy's cholesky, on an OpenBLAS of its own, within rounding), without their copies between memory
    orders (8 % of an evaluation at 256 samples; BLAS's triangular product in place of the last one is 30 %
    faster, but not to the bit)."""
    chol, failed = dpotrf(gram, lower=1, clean=0, overwrite_a=1)
    if failed:
        return None
    inverse_chol, failed = dtrtrs(chol, np.eye(len(gram), order="F"), lower=1, overwrite_b=1)
    if failed:
        return None
    return chol, inverse_chol.T @ inverse_chol


def linear_share(logit: float) -> float:
    return 1.0 / (1.0 + math.exp(-logit))


def row_noise(theta: np.ndarray, d: int, groups: np.ndarray, log_sn_floor: float) -> tuple[np.ndarray, np.ndarray]:
    """Each row's noise variance and each source's log noise sd (floored): source 0's is theta[d + 1], source
    j's theta[d + 2 + j]."""
    log_sn = np.maximum(np.concatenate([theta[d + 1:d + 2], theta[d + 3:]]), log_sn_floor)
    return np.exp(2.0 * log_sn)[groups], log_sn


def negative_log_posterior(theta: np.ndarray, xs: np.ndarray, ys: np.ndarray, prior_log_ell: float,
                           prior_ell_sd: float, log_sn_floor: float,
                           groups: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """-log p(ys | xs, theta) - log p(theta) and its gradient; ys (n, k) share the kernel, xs are
    centred. theta = (log ell per input, log sf, log sn, logit of the linear share); with `groups` (each
    row's source, 0 to g - 1), theta[d + 1] is source 0's log noise and g - 1 more follow, one per source."""
    d = xs.shape[1]
    ell, sf2 = np.exp(theta[:d]), math.exp(2.0 * theta[d])
    sn2, rho = math.exp(2.0 * max(theta[d + 1], log_sn_floor)), linear_share(theta[d + 2])
    z = xs / ell
    smooth, linear = kernel_shapes(z)
    smooth *= sf2 * (1.0 - rho)
    linear *= sf2 * rho
    gram = smooth + linear
    if groups is None:
        gram.flat[::len(xs) + 1] += sn2  # the diagonal: as + sn2 I, to the bit (every other entry is added a 0.0)
    else:
        row_sn2, log_sn = row_noise(theta, d, groups, log_sn_floor)
        gram.flat[::len(xs) + 1] += row_sn2
    factored = factor_and_invert(gram.T)  # (symmetric, so its transpose: Fortran order without a copy)
    if factored is None:
        return 1e12, np.zeros_like(theta)
    chol, inverse = factored
    alpha = inverse @ ys
    k = ys.shape[1]
    value = 0.5 * float((ys * alpha).sum()) + k * float(np.log(np.diag(chol)).sum())
    # d value / d gram = -w / 2, w = alpha alpha' - k inverse; with one output alpha alpha' is a product per
    # entry, as alpha @ alpha.T gives it (numpy's symmetric product copies its triangle over, 3x the time)
    if k == 1:
        w = alpha * alpha.T
        w -= inverse
    else:
        w = alpha @ alpha.T
        w -= k * inverse
    m = w * smooth
    m_sum = float(m.sum())
    grad = np.zeros_like(theta)
    # d smooth / d log ell_i = smooth * (z_ai - z_bi)^2 and d linear / d log ell_i = -2 linear * z_ai z_bi,
    # summed against w without forming either per input
    grad[:d] = -0.5 * (2.0 * (z * z).T @ m.sum(1) - 2.0 * (z * (m @ z)).sum(0))
    grad[:d] += sf2 * rho * (z * (w @ z)).sum(0)
    w_linear = float((w * linear).sum())
    grad[d] = -m_sum - w_linear
    if groups is None:
        grad[d + 1] = -float(np.trace(w)) * sn2 if theta[d + 1] > log_sn_floor else 0.0
    else:  # d value / d log sn_j = -sum over source j's rows of w_ii sn2_j
        per_source = -np.bincount(groups, weights=np.diag(w) * row_sn2, minlength=len(log_sn))
        per_source[np.concatenate([theta[d + 1:d + 2], theta[d + 3:]]) <= log_sn_floor] = 0.0
        grad[d + 1], grad[d + 3:] = per_source[0], per_source[1:]
    grad[d + 2] = -0.5 * ((1.0 - rho) * w_linear - rho * m_sum)
    ell_dev = (theta[:d] - prior_log_ell) / prior_ell_sd
    share_dev = theta[d + 2] / SHARE_PRIOR_SD
    value += 0.5 * float(ell_dev @ ell_dev) + 0.5 * (theta[d] / AMPLITUDE_PRIOR_SD) ** 2 + 0.5 * share_dev ** 2
    grad[:d] += ell_dev / prior_ell_sd
    grad[d] += theta[d] / AMPLITUDE_PRIOR_SD ** 2
    grad[d + 2] += share_dev / SHARE_PRIOR_SD
    return value, grad


def loo_residuals(xs: np.ndarray, ys: np.ndarray, found: Evidence, log_sn_floor: float,
                  groups: np.ndarray | None = None) -> np.ndarray:
    """The leave-one-out residuals (n, k) of normalised ys under the fit `found`: each sample against what
    the fit makes of all the others (Rasmussen & Williams 2006, 5.4.2). What the fit would answer where it
    was not shown: comparable between a region and its halves (gp_split), where the evidence (and the
    leave-one-out density, which rewards each half's own noise level) favours any cut of a trajectory."""
    z = xs / np.exp(found.log_ell)
    smooth, linear = kernel_shapes(z)
    sf2, rho = math.exp(2.0 * found.log_sf), linear_share(found.logit_linear)
    if groups is None:
        sn2 = math.exp(2.0 * max(found.log_sn, log_sn_floor))
        gram = sf2 * ((1.0 - rho) * smooth + rho * linear) + sn2 * np.eye(len(xs))
    else:
        noise = np.diag(row_noise(found.theta(), xs.shape[1], groups, log_sn_floor)[0])
        gram = sf2 * ((1.0 - rho) * smooth + rho * linear) + noise
    factored = factor_and_invert(gram.T)
    if factored is None or not np.isfinite(factored[1]).all():  # (non-finite: scipy's check raised here before)
        return np.full(ys.shape, np.inf)
    inverse = factored[1]
    return (inverse @ ys) / np.diag(inverse)[:, None]


def fit(xs: np.ndarray, ys: np.ndarray, start: Evidence, prior_ell_sd: float, noise_floor: float,
        max_iterations: int, log_sn_ceiling: float = 0.0, groups: np.ndarray | None = None) -> tuple[Evidence, float]:
    """The MAP hyper-parameters for normalised xs (n, d) and ys (n, k): the better of a climb from
    `start` (the last fit) and one from the prior, so that an early fit to a few noiseless-looking
    samples (short length scales, no noise) cannot hold every later one in its local optimum. The noise's
    log sd stays between the floor's and `log_sn_ceiling`, each source's where `groups` names each row's (0 to
    g - 1, `start` holding g - 1 more noises). Also returns the minimised -log posterior."""
    d = xs.shape[1]
    prior_log_ell = math.log(math.sqrt(d)) + SPARSITY
    log_sn_floor = 0.5 * math.log(noise_floor)
    log_sn_ceiling = min(max(log_sn_ceiling, log_sn_floor + math.log(2.0)), 0.0)
    more = 0 if groups is None else len(start.source_log_sn)
    bounds = [LOG_ELL_BOUNDS] * d + [LOG_SF_BOUNDS, (log_sn_floor, log_sn_ceiling), LOGIT_SHARE_BOUNDS] + \
        [(log_sn_floor, log_sn_ceiling)] * more
    low, high = [b[0] for b in bounds], [b[1] for b in bounds]
    prior = prior_start(d)
    if more:
        prior = Evidence(prior.log_ell, prior.log_sf, prior.log_sn, prior.logit_linear, np.full(more, prior.log_sn))
    starts = [np.clip(e.theta(), low, high) for e in (start, prior)]
    best, best_value = starts[0], math.inf
    for theta in starts:
        result = minimize(negative_log_posterior, theta, jac=True, method="L-BFGS-B", bounds=bounds,
                          args=(xs, ys, prior_log_ell, prior_ell_sd, log_sn_floor, groups),
                          options={"maxiter": max_iterations})
        if np.all(np.isfinite(result.x)) and result.fun < best_value:
            best, best_value = result.x, result.fun
    return Evidence(best[:d].copy(), float(best[d]), float(best[d + 1]), float(best[d + 2]),
                    best[d + 3:].copy() if more else None), float(best_value)


@dataclass(frozen=True)
class Hyper:
    """What a fit decides, in the data's own units: the outputs' mean (the answer far from all
    teaching), the inputs' centre (the linear part's origin), a log length scale per input, the
    normalised log amplitude and noise, the linear share's logit, and which inputs had varied."""

    mu: np.ndarray
    centre: np.ndarray
    log_ell: np.ndarray
    log_sf: float
    log_sn: float
    logit_linear: float
    varied: np.ndarray
    # fitted by source (gp.GP's numbering): each source's log noise, NaN for one the fit did not see (log_sn's);
    # None while a single source was fitted. log_sn is then the least of them
    source_log_sn: np.ndarray | None = None

    def noise_by_source(self, sources: np.ndarray, noise_floor: float) -> np.ndarray:
        """Each row's noise over the least noisy source's: how much less a row of `sources` weighs in the factor
        than a row of the most precise teacher; 1 for a source the fit did not see (and for all, fitted as one)."""
        noise = np.ones(len(sources))
        if self.source_log_sn is None:
            return noise
        own = np.where(np.isfinite(self.source_log_sn), self.source_log_sn, self.log_sn)
        floor = 0.5 * math.log(noise_floor)
        ratio = np.exp(2.0 * (np.maximum(own - self.log_sf, floor) - max(self.log_sn - self.log_sf, floor)))
        seen = (sources >= 0) & (sources < len(own))
        noise[seen] = ratio[sources[seen]]
        return noise


def first_hyper(n_in: int, n_out: int) -> Hyper:
    """Before any fit: unit-scale inputs, every one counting a little; no input known to vary."""
    start = prior_start(n_in)
    return Hyper(np.zeros(n_out), np.zeros(n_in), start.log_ell, start.log_sf, start.log_sn, start.logit_linear,
                 np.zeros(n_in, dtype=bool))


def spread_rows(m: int, count: int) -> np.ndarray:
    """Up to `count` row numbers spread evenly over m rows."""
    return np.unique(np.linspace(0, m - 1, min(count, m)).round().astype(int))


def fitted_rows(m: int, count: int, repeats: np.ndarray | None = None) -> np.ndarray:
    """The rows a fit sees: up to `count` spread evenly over m, and the rows taught again (`repeats` > 1), the
    places the teacher dwelt on, each weighing as many samples: up to a quarter of `count` more, the most
    repeated first (a fit's cost grows as its rows cubed)."""
    rows = spread_rows(m, count)
    if repeats is None:
        return rows
    dwelt = np.flatnonzero(repeats[:m] > 1.0)
    if len(dwelt) > count // 4:
        dwelt = dwelt[np.argsort(-repeats[dwelt], kind="stable")[:count // 4]]
    return np.union1d(rows, dwelt)


def fit_rows(xs: np.ndarray, ys: np.ndarray, last: Hyper, prior_ell_sd: float, noise_floor: float,
             max_iterations: int, noise_ceiling: np.ndarray | None = None,
             sources: np.ndarray | None = None) -> tuple[Hyper, float]:
    """The hyper-parameters for samples xs (n, n_in), ys (n, n_out), in units where each varying input
    and output has unit spread; the climb starts from `last` (and from the prior, see fit). The noise's
    sd stays under `noise_ceiling` (per output, in the outputs' units) for every output that varies.
    Also returns the fit's leave-one-out squared error, summed over samples and outputs in the outputs'
    own units (comparable between fits of different rows, as a split's halves against the whole:
    gp_split), inf when nothing varies. With `sources` (each row's teacher, gp.GP's numbering) naming more
    than one, each teacher's noise is fitted as its own: a person's reaction, a tick late, is that person's,
    not the whole map's."""
    mu, out_sd, centre, in_sd = ys.mean(0), ys.std(0), xs.mean(0), xs.std(0)
    varying_out = out_sd > 1e-12 * (1.0 + np.abs(mu))
    varied = in_sd > 1e-12 * (1.0 + np.abs(centre))
    if varied.any():  # and more than jitter (see JITTER_SHARE)
        varied &= in_sd > JITTER_SHARE * np.median(in_sd[varied])
    log_ell, log_sf, log_sn, logit_linear = last.log_ell.copy(), last.log_sf, last.log_sn, last.logit_linear
    present = None if sources is None else np.unique(sources)
    by_source, groups = None, None
    loo_error = math.inf
    if varying_out.any() and varied.any():
        norm_x = (xs[:, varied] - centre[varied]) / in_sd[varied]
        norm_y = (ys[:, varying_out] - mu[varying_out]) / out_sd[varying_out]
        more = None
        if present is not None and len(present) > 1:
            groups = np.searchsorted(present, sources)
            known = last.source_log_sn
            starts = [known[p] if known is not None and p < len(known) and np.isfinite(known[p]) else log_sn
                      for p in present]
            log_sn, more = starts[0], np.array(starts[1:])
        start = Evidence(log_ell[varied] - np.log(in_sd[varied]), log_sf, log_sn, logit_linear, more)
        ceiling = 0.0
        if noise_ceiling is not None:
            ceiling = math.log(max(float(np.min(noise_ceiling[varying_out] / out_sd[varying_out])), 1e-300))
        found, _ = fit(norm_x, norm_y, start, prior_ell_sd, noise_floor, max_iterations, ceiling, groups)
        log_ell[varied] = found.log_ell + np.log(in_sd[varied])
        log_sf, log_sn, logit_linear = found.log_sf, found.log_sn, found.logit_linear
        if groups is not None:
            own = np.concatenate([[found.log_sn], found.source_log_sn])
            by_source = np.full(int(present[-1]) + 1, np.nan)
            by_source[present] = own
            log_sn = float(own.min())
        residuals = loo_residuals(norm_x, norm_y, found, 0.5 * math.log(noise_floor), groups) * out_sd[varying_out]
        loo_error = float((residuals * residuals).sum())
    # an input that never varied keeps the prior's length scale in its own units: moving it is new
    # (the envelope says so) but changes the answer little, as the paper's orange ball did
    log_ell[~varied] = prior_start(len(centre)).log_ell[0]
    return Hyper(mu, centre, log_ell, log_sf, log_sn, logit_linear, varied, by_source), loo_error


def prior_start(d: int) -> Evidence:
    """Where a first fit starts: every input equally relevant, amplitude as taught, a little noise,
    the prior variance shared evenly between the smooth and the linear part."""
    return Evidence(np.full(d, math.log(math.sqrt(d))), 0.0, math.log(0.1), 0.0)


__all__ = ["Evidence", "Hyper", "first_hyper", "fit", "fit_rows", "linear_share",
           "negative_log_posterior", "prior_start", "spread_rows", "fitted_rows"]
