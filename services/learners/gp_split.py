"""Whether a GP leaf's samples are two regions, each better explained by a GP of its own: the tree's
(gp.py) reason to split. A comparison of fits, as treed GPs make it (Gramacy & Lee 2008), greedily: the
leaf's fit against the two halves' fits, along the inputs its samples span the most length scales of.

A pendulum's teacher pumps energy by the angle's cosine and rate and catches it at the top by the
angle's sine: one GP over both calls the sine irrelevant (its length scale 3, where the catch needs
0.3) and the student never catches; cut along the cosine, each half explains its own.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .gp_evidence import Hyper, fit_rows, fitted_rows

CANDIDATES = 2  # inputs tried, those the leaf's samples span the most length scales of
MIN_SIDE = 0.1  # of the rows, the least either half holds
# A cut must remove MIN_GAIN of the leave-one-out squared error (what each sample's fit from the others
# misses), and the halves must disagree on what matters: an input that one half's samples span at least
# MATTERS length scales of, with length scales RELEVANCE_RATIO apart. Judged by either alone, nearly any cut
# of a robot's trajectory looks better (halves of a smooth map fitted apart remove 30-60 % of the error on
# 50 samples); random smooth maps cut so lost half their accuracy (benchmarks/unknown.py)
MIN_GAIN, MATTERS, RELEVANCE_RATIO = 0.2, 0.5, 2.0  # the ratio as a log: e^2, 7x


def relevance_differs(xs: np.ndarray, left: np.ndarray, left_fit: Hyper, right_fit: Hyper) -> bool:
    """Whether the halves' fits disagree on an input that matters to either (see RELEVANCE_RATIO)."""
    both = left_fit.varied & right_fit.varied
    matters = (xs[left].std(0) > MATTERS * np.exp(left_fit.log_ell)) | \
        (xs[~left].std(0) > MATTERS * np.exp(right_fit.log_ell))
    apart = np.abs(left_fit.log_ell - right_fit.log_ell)
    return bool(np.any(apart[both & matters] >= RELEVANCE_RATIO))


@dataclass(frozen=True)
class Split:
    """Cut at x[input] <= threshold (left) or above (right), with each half's fit."""
    input: int
    threshold: float
    left: Hyper
    right: Hyper
    gain: float


def fit_and_split(xs: np.ndarray, ys: np.ndarray, last: Hyper, fit_points: int, prior_ell_sd: float,
                  noise_floor: float, max_iterations: int, noise_ceiling: np.ndarray | None,
                  consider: bool, repeats: np.ndarray | None = None,
                  sources: np.ndarray | None = None) -> tuple[Hyper, Split | None]:
    """The leaf's fit (gp_evidence.fit_rows on up to `fit_points` rows spread over its memory, and the places
    taught again: gp_evidence.fitted_rows, with the leaf's `repeats`) and, when
    `consider`, the best cut (at the middle of the range of one of the CANDIDATES inputs) that removes
    MIN_GAIN of the leave-one-out error between halves that disagree on what matters, else None. `sources`: each
    row's teacher (gp_evidence.fit_rows fits each one's noise). A pure
    function: it runs in the fitter's process when serving live."""
    rows = fitted_rows(len(xs), fit_points, repeats)
    xs, ys = xs[rows], ys[rows]
    sources = None if sources is None else sources[rows]
    settings = (prior_ell_sd, noise_floor, max_iterations, noise_ceiling)
    hyper, whole = fit_rows(xs, ys, last, *settings, sources=sources)
    if not consider or not np.isfinite(whole) or whole <= 0.0:
        return hyper, None
    spans = xs.std(0) * np.exp(-hyper.log_ell) * hyper.varied
    best = None
    for i in np.argsort(-spans, kind="stable")[:CANDIDATES]:
        if spans[i] <= 0.0:
            break
        threshold = float((xs[:, i].min() + xs[:, i].max()) / 2)
        left = xs[:, i] <= threshold
        if not MIN_SIDE * len(xs) <= left.sum() <= (1.0 - MIN_SIDE) * len(xs):
            continue
        (left_hyper, left_error), (right_hyper, right_error) = (
            fit_rows(xs[side], ys[side], hyper, *settings, sources=None if sources is None else sources[side])
            for side in (left, ~left))
        gain = 1.0 - (left_error + right_error) / whole  # the share of the leave-one-out error the cut removes
        if gain > MIN_GAIN and relevance_differs(xs, left, left_hyper, right_hyper) and \
                (best is None or gain > best.gain):
            best = Split(int(i), threshold, left_hyper, right_hyper, float(gain))
    return hyper, best
