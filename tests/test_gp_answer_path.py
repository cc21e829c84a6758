"""Served live, a GP leaf answers from alpha = chol^-T beta and a float32 copy of its factor (issue 34), made
current after each change to the factor: its answers are the exact posterior's (gp_kernels.predict_exact over
the factor as it is) through appends, samples weighed again, thinnings and rebuilds."""
import numpy as np

from services.learners import gp_kernels, make_learner
from services.learners.unknown_tasks import draw_task

N_IN = 6


class FitUnderWay:
    """A fit that never ends: the leaf starts no other (no fitting process in a unit test)."""

    def done(self) -> bool:
        return False


def served_leaf(memory: int = 120):
    """A one-leaf GP taught offline, then served live with a fit forever under way, and the rest of its stream."""
    task = draw_task(5, -np.ones(N_IN), np.ones(N_IN), -np.ones(2), np.ones(2), relevant=(2, 3), taught=(2, 2))
    xs = task.stream(20.0, 30.0, "trajectory")
    ys = task.target(xs)
    model = make_learner("gp", N_IN, 2, seed=0, memory=memory, leaves=1)
    for x, y in zip(xs[:200], ys[:200]):
        model.learn_one(x, y)
    leaf = model.parts[0]
    leaf._background, leaf._pending = True, (FitUnderWay(), None)
    return model, leaf, xs[200:], ys[200:]


def answers(leaf, x):
    """(offsets, unit variance) by the served path and by the exact one, over the leaf's factor as it is."""
    leaf._ready_to_answer()
    args = (leaf._m, np.ascontiguousarray(x), leaf._inv_ell, leaf._hyper.centre, leaf._smooth, leaf._linear,
            leaf._ratio)
    fast, exact = np.empty(leaf.n_out), np.empty(leaf.n_out)
    fast_var = gp_kernels.predict_one(leaf._xs, leaf._chol32, leaf._alpha, *args, fast)
    exact_var = gp_kernels.predict_exact(leaf._xs, leaf._chol, leaf._beta, *args, exact)
    return fast, fast_var, exact, exact_var


def test_served_live_answers_are_the_exact_posterior_through_every_change_to_the_factor():
    model, leaf, xs, ys = served_leaf()
    rng = np.random.default_rng(0)
    span = leaf._taught.span
    worst_mean, worst_var, thins, reweighed = 0.0, 0.0, leaf._thins, 0
    for i, (x, y) in enumerate(zip(xs[:260], ys[:260])):
        if i % 6 == 5:  # a place taught again (weighed again: a rank-one update), now and then with another answer
            j = int(rng.integers(leaf._m))
            x, y = leaf._xs[j].copy(), leaf._ys[j] + (0.3 * span if i % 12 == 5 else 0.0)
            reweighed += 1
        p = model.predict_one(x)
        model.learn_one(x, y)
        fast, fast_var, exact, exact_var = answers(leaf, x + rng.normal(0.0, 0.05, N_IN))
        worst_mean = max(worst_mean, float(np.max(np.abs(fast - exact) / span)))
        worst_var = max(worst_var, abs(fast_var - exact_var))
        assert np.all(np.isfinite(p.y)) and 0.0 <= p.confidence <= 1.0
    assert leaf._thins > thins and reweighed >= 40  # thinned (rebuilt) and weighed again along the way
    assert worst_mean < 1e-9, worst_mean  # the mean: to rounding
    assert worst_var < 1e-4, worst_var  # the unit variance: float32's rounding, far under what moves a confidence


def test_a_served_answer_is_the_offline_answer_to_rounding():
    """The whole answer (held range, confidence, envelope) from the served path, against the same leaf offline."""
    model, leaf, xs, _ = served_leaf(memory=400)
    for x in xs[:100:7]:
        served = model.predict_one(x)
        leaf._background = False
        offline = model.predict_one(x)
        leaf._background = True
        assert np.allclose(served.y, offline.y, rtol=0.0, atol=1e-9 * leaf._taught.span.max())
        assert abs(served.confidence - offline.confidence) < 1e-4


def test_a_snapshot_leaves_out_the_answers_copies_and_a_restored_leaf_makes_them_again():
    model, leaf, xs, _ = served_leaf(memory=400)
    before = model.predict_one(xs[0])
    state = leaf.__getstate__()
    assert "_chol32" not in state and "_alpha" not in state
    restored = type(model).restore(model.snapshot())
    restored.parts[0]._background = True
    again = restored.predict_one(xs[0])
    assert np.allclose(before.y, again.y, rtol=0.0, atol=1e-12) and abs(before.confidence - again.confidence) < 1e-12
