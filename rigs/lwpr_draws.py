"""LWPR's accuracy protocols over independent data draws, shared by benchmarks/learners.py and tests.

A case is one data draw of one protocol: a training stream in update order, held-out inputs and their
noise-free truth. Draw d seeds the data and the order, so it means the same data for our LWPR and for
the reference library (benchmarks/lib/lwpr_reference.py).

- cross: the LWPR tutorial: 500 noisy points (sd 0.1), 20 epochs shuffled, the 41x41 noise-free grid.
- irrelevant20: 20,000 fresh samples of cross among 18 irrelevant inputs (20-D), 2000 held-out.
- mirror: the paper's mirroring, 18 -> 18, 20,000 samples; held-out worst error over 500 points.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigs.tasks import cross, cross_embedded, cross_grid, cross_training, mirror_samples, nmse, worst_error
from services.learners import make_learner

MIRROR_THRESHOLD = 0.05  # rad, worst held-out error


@dataclass(frozen=True)
class Case:
    xs: np.ndarray
    ys: np.ndarray
    test: np.ndarray
    truth: np.ndarray


def cross_case(draw: int, points: int = 500, epochs: int = 20) -> Case:
    xs, ys = cross_training(points, seed=draw)
    order = np.random.default_rng(draw + 1000).permutation(np.tile(np.arange(points), epochs))
    grid, truth = cross_grid()
    return Case(xs[order], ys[order], grid, truth)


def irrelevant_case(draw: int, samples: int = 20_000, dims: int = 20) -> Case:
    xs, ys = cross_embedded(samples, dims=dims, seed=draw)
    test = np.random.default_rng(draw + 7).uniform(-1.0, 1.0, (2000, dims))
    return Case(xs, ys, test, cross(test[:, :2]))


def mirror_case(draw: int, samples: int = 20_000) -> Case:
    xs, ys = mirror_samples(samples, seed=draw)
    test, truth = mirror_samples(500, seed=draw + 100)
    return Case(xs, ys, test, truth)


def final_nmse(case: Case, params: dict) -> float:
    """nMSE on the held-out inputs after the whole stream."""
    model = make_learner("lwpr", case.xs.shape[1], case.ys.shape[1], seed=0, **params)
    model.learn_many(case.xs, case.ys)
    return nmse(model.predict_many(case.test).y, case.truth)


def mirror_checkpoints(samples: int) -> list[int]:
    """Every 10 samples up to 1000, then every 250."""
    return [n for n in range(10, min(samples, 1000) + 1, 10)] + list(range(1250, samples + 1, 250))


def samples_until_good(errors: dict[int, float]) -> int | None:
    """The first checkpoint from which the worst error stays under MIRROR_THRESHOLD; None if it never does."""
    good = None
    for seen in sorted(errors):
        good = (good or seen) if errors[seen] < MIRROR_THRESHOLD else None
    return good


def mirror_samples_until_good(case: Case, params: dict) -> int | None:
    """Samples until the held-out worst error stays under the threshold (None: never)."""
    model = make_learner("lwpr", 18, 18, seed=0, **params)
    errors, done = {}, 0
    for seen in mirror_checkpoints(len(case.xs)):
        model.learn_many(case.xs[done:seen], case.ys[done:seen])
        done = seen
        errors[seen] = worst_error(model.predict_many(case.test).y, case.truth)
    return samples_until_good(errors)

