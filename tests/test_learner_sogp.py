"""SOGP specifics beyond the shared conformance suite."""
import numpy as np

from rigs.tasks import cross, nmse
from services.learners import make_learner


def test_long_stream_stays_stable():
    """Regression: with few basis vectors and 40,000 mostly projected updates, rounding
    once made the posterior variance negative and the predictions explode (nMSE 23)."""
    rng = np.random.default_rng(6)  # a stream that exploded before the fix
    xs = rng.uniform(-1, 1, (40_000, 2))
    ys = cross(xs) + rng.normal(0, 0.1, (40_000, 1))
    model = make_learner("sogp", 2, 1)
    model.learn_many(xs, ys)
    test = rng.uniform(-1, 1, (1000, 2))
    prediction = model.predict_many(test)
    assert np.abs(prediction.y).max() < 2.0
    assert nmse(prediction.y, cross(test)) < 0.5
    assert np.all((prediction.confidence >= 0) & (prediction.confidence <= 1))


def test_capacity_bounds_the_basis():
    model = make_learner("sogp", 3, 1, capacity=25, length_scale=0.3)
    xs = np.random.default_rng(0).uniform(-1, 1, (500, 3))
    model.learn_many(xs, np.sin(3 * xs[:, :1]))
    assert model.size == 25
