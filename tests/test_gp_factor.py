"""Served live, a fit's factor is built in the fitter's process over the memory the fit saw and extended on the
answer path by what was taught since (services.learners.gp_factor): the factor of the memory as it is, whatever
was appended or weighed again meanwhile, and a rebuild wherever that cannot hold."""
import numpy as np
import pytest

from services.learners import make_learner
from services.learners.gp_evidence import first_hyper
from services.learners.gp_factor import MOST_REWEIGHED, extend, factor_live, shape_of
from services.learners.unknown_tasks import draw_task
from services.waiting import poll
from tests.test_gp_answer_path import answers

N_IN, N_OUT, M = 4, 2, 60


def memory(seed: int = 0, n_out: int = N_OUT):
    rng = np.random.default_rng(seed)
    xs = rng.uniform(-1.0, 1.0, (M, N_IN))
    residual = np.column_stack([np.sin((2.0 + o) * xs[:, o % N_IN]) * xs[:, (o + 1) % N_IN] for o in range(n_out)])
    hyper = first_hyper(N_IN, n_out)
    return xs, residual, hyper, shape_of(hyper, 1e-5)


def whole(xs, residual, repeats, hyper, shape):
    built = factor_live(xs, M, repeats, hyper.centre, shape)
    beta = np.linalg.solve(built.chol, residual)
    return built.chol, beta


@pytest.mark.parametrize("n_out", [N_OUT, 18])  # beta by the compiled loop, by LAPACK
@pytest.mark.parametrize("seen_m,reweighed", [(M, []), (40, []), (40, [3, 45]), (M, [0, 7, 59]), (25, [24, 26])])
def test_an_extended_factor_is_the_factor_of_the_memory_as_it_is(seen_m, reweighed, n_out):
    xs, residual, hyper, shape = memory(n_out=n_out)
    seen_repeats = np.ones(M)
    seen_repeats[[1, 2]] = 3.0  # weighed again before the fit saw them
    built = factor_live(xs, seen_m, seen_repeats, hyper.centre, shape)
    repeats = seen_repeats.copy()
    repeats[seen_m:] = 1.0
    for row in reweighed:
        repeats[row] += 2.0
    chol, beta = np.zeros((M, M)), np.zeros((M, n_out))
    assert extend(built, seen_m, seen_repeats, xs, residual, repeats, M, hyper.centre, shape, chol, beta)
    want_chol, want_beta = whole(xs, residual, repeats, hyper, shape)
    assert np.allclose(chol, want_chol, atol=1e-9)
    assert np.allclose(beta, want_beta, atol=1e-7)
    assert np.all(np.triu(chol, 1) == 0.0)  # the appends rely on a lower triangular factor


def test_too_many_rows_weighed_again_are_left_to_a_rebuild():
    xs, residual, hyper, shape = memory()
    built = factor_live(xs, M, np.ones(M), hyper.centre, shape)
    repeats = np.ones(M)
    repeats[:MOST_REWEIGHED + 1] = 2.0
    chol, beta = np.zeros((M, M)), np.zeros((M, N_OUT))
    assert not extend(built, M, np.ones(M), xs, residual, repeats, M, hyper.centre, shape, chol, beta)
    assert not chol.any()  # declined before touching it


def answers_from_the_factor(leaf) -> bool:
    """Whether the served answer's alpha and float32 factor (gp_kernels.predict_one) are the landed factor's."""
    fast, fast_var, exact, exact_var = answers(leaf, leaf._xs[0] + 0.01)
    return bool(np.allclose(fast, exact, rtol=0.0, atol=1e-9) and abs(fast_var - exact_var) < 1e-4)


@pytest.mark.live
def test_served_live_each_fit_lands_with_the_factor_of_what_the_leaf_remembers():
    """A leaf taught live while its fits run aside, its memory small so that the fitter thins it too: every fit
    lands with the exact factor of the memory as it then is, nearly all without a rebuild on the answer path, and
    the memory never holds more than its room."""
    task = draw_task(3, -np.ones(6), np.ones(6), -np.ones(1), np.ones(1), relevant=(2, 2), taught=(1, 1))
    xs = task.stream(40.0, 30.0, "trajectory")
    ys = task.target(xs)
    model = make_learner("gp", 6, 1, seed=0, memory=160, leaves=1)
    model.serve_live()
    leaf = model.parts[0]
    counts = {"landed": 0, "thinned aside": 0, "rebuilt on landing": 0, "wrong": 0, "most held": 0,
              "answer not the factor's": 0}
    adopt, rebuild = leaf._adopt, leaf._rebuild
    rebuilt = [0]

    def rebuilding():
        rebuilt[0] += 1
        rebuild()

    def adopting(found, seen):
        before, thins = rebuilt[0], leaf._thins
        adopt(found, seen)
        counts["landed"] += 1
        counts["thinned aside"] += leaf._thins - thins
        if rebuilt[0] > before:
            counts["rebuilt on landing"] += 1
            return
        m = leaf._m
        chol, beta = leaf._chol[:m, :m].copy(), leaf._beta[:m].copy()
        counts["answer not the factor's"] += int(not answers_from_the_factor(leaf))
        rebuild()  # the factor from scratch, to compare
        counts["wrong"] += int(not (np.allclose(chol, leaf._chol[:m, :m], atol=1e-8)
                                    and np.allclose(beta, leaf._beta[:m], atol=1e-6)))
    leaf._adopt, leaf._rebuild = adopting, rebuilding
    for i, (x, y) in enumerate(zip(xs, ys)):
        model.predict_one(x)
        model.learn_one(x, y)
        counts["most held"] = max(counts["most held"], leaf._m)
        if i % 8 == 0:  # as a robot's ticks come: a fit lands some ticks after it started, not hundreds
            poll(lambda: leaf._pending is None or leaf._pending[0].done(), 30.0)

    def settled() -> bool:
        model.predict_one(xs[0])
        return leaf._pending is None
    poll(settled, 60.0)
    assert counts["landed"] >= 10 and counts["thinned aside"] >= 3, counts
    assert counts["wrong"] == 0 and counts["answer not the factor's"] == 0, counts
    assert counts["rebuilt on landing"] <= counts["landed"] // 4, counts
    assert counts["most held"] <= 160 + 160 // 16, counts
