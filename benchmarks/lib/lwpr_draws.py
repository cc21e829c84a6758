"""LWPR's accuracy protocols over independent data draws, shared by benchmarks/learners.py and tests.

`tutorial` is the LWPR tutorial's cross: 500 noisy points (noise sd 0.1) of one draw, 20 epochs in a
shuffled order, nMSE on the noise-free 41x41 grid. `irrelevant` streams fresh samples of cross whose
inputs carry `dims - 2` irrelevant ones, nMSE on 2000 held-out points. Draw d seeds both the data
and the order, so a draw means the same data whatever the learner.
"""
from __future__ import annotations

import numpy as np

from services.learners import make_learner
from benchmarks.lib.tasks import cross, cross_embedded, cross_grid, cross_training, nmse


def tutorial_stream(draw: int, points: int = 500, epochs: int = 20) -> tuple[np.ndarray, np.ndarray]:
    xs, ys = cross_training(points, seed=draw)
    order = np.random.default_rng(draw + 1000).permutation(np.tile(np.arange(points), epochs))
    return xs[order], ys[order]


def tutorial(draw: int, params: dict, points: int = 500, epochs: int = 20) -> tuple[float, int]:
    """(nMSE, receptive fields) of LWPR with `params` taught one tutorial draw."""
    xs, ys = tutorial_stream(draw, points, epochs)
    model = make_learner("lwpr", 2, 1, seed=0, **params)
    model.learn_many(xs, ys)
    grid, truth = cross_grid()
    return nmse(model.predict_many(grid).y, truth), model.size


def irrelevant_stream(draw: int, samples: int, dims: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Training (xs, ys) and held-out (inputs, noise-free truth) of cross among irrelevant inputs."""
    xs, ys = cross_embedded(samples, dims=dims, seed=draw)
    test = np.random.default_rng(draw + 7).uniform(-1.0, 1.0, (2000, dims))
    return xs, ys, test, cross(test[:, :2])


def irrelevant(draw: int, params: dict, samples: int = 20_000, dims: int = 20) -> tuple[float, int]:
    xs, ys, test, truth = irrelevant_stream(draw, samples, dims)
    model = make_learner("lwpr", dims, 1, seed=0, **params)
    model.learn_many(xs, ys)
    return nmse(model.predict_many(test).y, truth), model.size
