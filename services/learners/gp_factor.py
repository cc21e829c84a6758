"""The GP leaf's factor served live (gp_local.LocalGP): built by the compiled kernel matrix, and, for a fit
done in the fitter's process, built there too, over the memory the fit saw (thinned there, once full), so
that the answer path only extends it by what was taught since (issue 34: at 800 samples a rebuild took
5-10 ms of the call that applied a fit, which in a lesson is every few ticks, or thinned the memory).

Offline nothing here runs: the factor is rebuilt by numpy as ever, so that every replay and benchmark
answers as before to the last bit.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy.linalg import solve_triangular
from scipy.linalg.lapack import dpotrf as potrf

from . import gp_kernels
from .gp_evidence import Hyper, linear_share
from .gp_memory import densest_older

# rows whose weight (gp_repeats) changed since the fit's snapshot, each a rank-one update of O(m^2); past this
# many, rebuilding the factor is as cheap
MOST_REWEIGHED = 8
# beta solved by the compiled loop for up to this many outputs, by LAPACK for more (at 800 rows: one output 0.26
# against 0.32 ms, 18 outputs 3.1 against 0.55)
FEW_OUTPUTS = 2


class Shape(NamedTuple):
    """The kernel's working quantities of a fit: inverse length scales, the smooth and linear shares of the prior
    variance, and the noise over amplitude ratio."""
    inv_ell: np.ndarray
    smooth: float
    linear: float
    ratio: float


class Built(NamedTuple):
    """A factor built in the fitter's process over the rows it saw, with the noise ratio it needed (raised
    tenfold on each rounding failure, as the answer path's own build does)."""
    chol: np.ndarray
    ratio: float


def shape_of(hyper: Hyper, noise_floor: float) -> Shape:
    linear = linear_share(hyper.logit_linear)
    return Shape(np.exp(-hyper.log_ell), 1.0 - linear, linear,
                 max(math.exp(2.0 * (hyper.log_sn - hyper.log_sf)), noise_floor))


def factor_live(xs: np.ndarray, m: int, repeats: np.ndarray, centre: np.ndarray, shape: Shape,
                noise: np.ndarray | None = None) -> Built:
    """The lower Cholesky factor of the kernel matrix plus noise over the first m rows: the matrix's lower
    triangle compiled (numpy's whole matrix took 10-18 ms of a 20 ms rebuild at 800 samples), factored in place
    (C order's lower triangle is Fortran order's upper one). `noise`: each row's noise over the fit's (its
    teacher's, Hyper.noise_by_source), 1 where None."""
    unit = np.empty((m, m))
    gp_kernels.gram(xs, m, shape.inv_ell, centre, shape.smooth, shape.linear, unit)
    ratio = shape.ratio
    while True:
        gram = unit.copy()
        gram.flat[::m + 1] += (ratio if noise is None else ratio * noise[:m]) / repeats[:m]
        upper, failed = potrf(gram.T, lower=0, clean=1, overwrite_a=1)
        if failed == 0:
            return Built(upper.T, ratio)
        ratio *= 10.0  # rounding on near-duplicates: more noise, never a crash


def fit_and_build(job, repeats: np.ndarray, born: np.ndarray, drop: int, noise_floor: float,
                  sources: np.ndarray | None = None) -> tuple:
    """In the fitter's process: the fit `job` (gp_split.fit_and_split over the leaf's memory, `job.args[0]`, no
    split considered); where `drop` > 0 the memory thinned under that fit as LocalGP._thin would (gp_memory:
    the rows kept, else None); and the factor over the rows kept under the fit (each row's noise its teacher's,
    `sources`)."""
    hyper, split = job(False)
    xs = job.args[0]
    shape = shape_of(hyper, noise_floor)
    keep = np.flatnonzero(~densest_older(xs * shape.inv_ell, born, drop)) if drop > 0 else None
    rows = np.arange(len(xs)) if keep is None else keep
    noise = None if sources is None or hyper.source_log_sn is None else \
        hyper.noise_by_source(sources[rows], noise_floor)
    return hyper, split, factor_live(xs[rows], len(rows), repeats[rows], hyper.centre, shape, noise), keep


def extend(built: Built, seen_m: int, seen_repeats: np.ndarray, xs: np.ndarray, residual: np.ndarray,
           repeats: np.ndarray, m: int, centre: np.ndarray, shape: Shape, chol: np.ndarray,
           beta: np.ndarray, noise: np.ndarray | None = None) -> bool:
    """chol and beta over the first m rows, from `built` over the first seen_m (the same rows, each then weighed
    seen_repeats): the rows taught since appended, the weights changed since updated. False, chol and beta
    not to be used, when that would cost about a rebuild or rounding defeats it. `noise`: each row's over the
    fit's (factor_live)."""
    weighed = np.concatenate([seen_repeats[:seen_m], np.ones(m - seen_m)])
    changed = np.flatnonzero(weighed != repeats[:m])
    if len(changed) > MOST_REWEIGHED:
        return False
    chol[:seen_m, :seen_m] = built.chol
    solve_beta(chol, beta, residual, seen_m, 0)
    before = np.empty(beta.shape[1])
    for row in range(seen_m, m):
        gp_kernels.append(xs, chol, beta, row, xs[row], residual[row], shape.inv_ell, centre, shape.smooth,
                          shape.linear, built.ratio if noise is None else built.ratio * noise[row], before)
    for row in changed:
        ratio = built.ratio if noise is None else built.ratio * noise[row]
        if not gp_kernels.reweigh(chol, m, int(row), ratio * (1.0 / repeats[row] - 1.0 / weighed[row])):
            return False
    if len(changed):
        solve_beta(chol, beta, residual, m, int(changed.min()))
    return True


def solve_beta(chol: np.ndarray, beta: np.ndarray, residual: np.ndarray, m: int, start: int) -> None:
    """beta = chol^-1 residual over the first m rows, those before `start` unchanged."""
    if beta.shape[1] <= FEW_OUTPUTS:
        gp_kernels.resolve(chol, beta, residual, m, start)
    else:
        beta[:m] = solve_triangular(chol[:m, :m], residual[:m], lower=True)
