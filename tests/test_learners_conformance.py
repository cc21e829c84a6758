"""Every registered learner against every conformance check (ids like lwpr:check_...)."""
import numpy as np
import pytest

from services.learners import LEARNERS, LearnerInputError, UnknownLearnerError, make_learner
from services.learners.checks import ALL_CHECKS, check_more_teaching_is_not_worse_closed_loop, unit_test_factory

SLOW_CHECKS = {check_more_teaching_is_not_worse_closed_loop}  # a closed-loop lesson each: the GP's takes 11 s
CASES = [pytest.param(name, check, id=f"{name}:{check.__name__}",
                      marks=pytest.mark.slow if check in SLOW_CHECKS else ())
         for name in LEARNERS for check in ALL_CHECKS]


@pytest.mark.parametrize("name,check", CASES)
def test_conformance(name, check):
    check(unit_test_factory(LEARNERS[name]))


def test_registry_names():
    assert set(LEARNERS) >= {"lwpr", "sogp", "knn"}


def test_unknown_learner_lists_known_names():
    with pytest.raises(KeyError) as caught:
        make_learner("gpr", 2, 1)
    assert isinstance(caught.value, UnknownLearnerError)
    assert "known learners: gp, knn, lwpr, per-output, sogp" in str(caught.value)


@pytest.mark.parametrize("name", sorted(LEARNERS))
def test_unknown_hyper_parameter_is_named(name):
    with pytest.raises(ValueError, match="unknown hyper-parameter 'flux'"):
        make_learner(name, 2, 1, flux=3)


@pytest.mark.parametrize("name,param,value", [
    ("lwpr", "w_gen", 2.0), ("lwpr", "init_D", -1.0), ("lwpr", "meta", "yes"), ("lwpr", "norm_in", (1.0, 0.0)),
    ("sogp", "capacity", 0), ("sogp", "noise_var", -1.0), ("knn", "k", 0),
])
def test_invalid_hyper_parameter_is_named(name, param, value):
    with pytest.raises(ValueError, match=param):
        make_learner(name, 2, 1, **{param: value})


@pytest.mark.parametrize("name", sorted(LEARNERS))
def test_params_rebuild_the_same_learner(name):
    model = make_learner(name, 4, 2, seed=3)
    twin = make_learner(name, 4, 2, seed=3, **model.get_params())
    assert twin.get_params() == model.get_params() and twin.seed == 3


def test_input_error_is_a_value_error():
    assert issubclass(LearnerInputError, ValueError)


@pytest.mark.parametrize("name", sorted(LEARNERS))
def test_compiling_before_going_live_leaves_the_learner_as_it_was(name):
    """The learner box compiles each learner's kernels on a throw-away clone before it says it is ready
    (the old warm_up, used by nothing, was tested only for elapsed >= 0)."""
    import numpy as np

    from services.learners import compile_kernels
    model = make_learner(name, 3, 2, seed=1)
    before = model.snapshot()
    compile_kernels(model)
    assert model.n_learned == 0 and model.snapshot() == before
    if name == "lwpr":
        from services.learners import lwpr_kernels
        assert lwpr_kernels.learn_one.signatures and lwpr_kernels.predict_one.signatures
    assert np.isfinite(model.predict_one(np.zeros(3)).y).all()


@pytest.mark.parametrize("name", sorted(LEARNERS))
@pytest.mark.parametrize("n_in,n_out", [(1, 1), (1, 3), (30, 2)])
def test_any_input_and_output_sizes(name, n_in, n_out):
    import numpy as np

    model = make_learner(name, n_in, n_out)
    xs = np.random.default_rng(0).uniform(-1, 1, (50, n_in))
    model.learn_many(xs, np.tile(np.sin(xs[:, :1]), (1, n_out)))
    prediction = model.predict_many(xs)
    assert prediction.y.shape == (50, n_out) and prediction.confidence.shape == (50,)
    assert np.isfinite(prediction.y).all()


def test_per_output_learns_only_the_taught_outputs():
    model = make_learner("per-output", 2, 2, base="knn")
    rng = np.random.default_rng(0)
    for x in rng.uniform(-1, 1, (200, 2)):
        model.learn_one(x, [x[0], 5.0], mask=[1, 0])  # output 1 untaught: its 5.0 must not be learned
    for x in rng.uniform(-1, 1, (200, 2)):
        model.learn_one(x, [9.0, x[1]], mask=[0, 1])  # output 0 untaught now
    p = model.predict_one([0.3, -0.4])
    assert abs(p.y[0] - 0.3) < 0.15 and abs(p.y[1] + 0.4) < 0.15, p.y
