"""Acceptance at small sizes: LWPR learns the tutorial's cross and the paper's mirroring."""
import numpy as np

from services.learners import make_learner
from rigs.tasks import (
    CROSS_LWPR_PARAMS, cross_grid, cross_training, mirror_samples, nmse, worst_error,
)


def test_lwpr_learns_cross_within_10k_samples():
    xs, ys = cross_training(500, seed=0)
    model = make_learner("lwpr", 2, 1, seed=0, **CROSS_LWPR_PARAMS)
    order = np.random.default_rng(1).permutation(np.tile(np.arange(500), 20))
    model.learn_many(xs[order], ys[order])
    grid, truth = cross_grid()
    assert model.n_learned == 10_000
    assert nmse(model.predict_many(grid).y, truth) < 0.1


def test_lwpr_learns_mirroring_within_1000_samples():
    model = make_learner("lwpr", 18, 18, seed=0)
    xs, ys = mirror_samples(1000, seed=0)
    for x, y in zip(xs, ys):
        model.learn_one(x, y)
    held_out, truth = mirror_samples(1000, seed=1)
    prediction = model.predict_many(held_out)
    assert worst_error(prediction.y, truth) < 0.05
    assert np.median(model.predict_many(xs).confidence) > 0.5  # it knows it has learned


def test_lwpr_knows_it_does_not_know_before_teaching_far_away():
    model = make_learner("lwpr", 18, 18, seed=0)
    model.learn_many(*mirror_samples(300, seed=0))
    assert model.predict_one(np.full(18, 4.0)).confidence < 0.25


def test_lwpr_mirroring_within_300_samples_the_papers_ten_seconds():
    model = make_learner("lwpr", 18, 18, seed=0)
    model.learn_many(*mirror_samples(300, seed=0))
    held_out, truth = mirror_samples(1000, seed=1)
    assert worst_error(model.predict_many(held_out).y, truth) < 0.05
