"""Conformance suite every learner must pass (river's `checks` habit).

Each check takes `make(seed=0) -> Learner`, a factory of fresh learners with 3 inputs and
2 outputs, and raises AssertionError with a reason when the learner breaks the contract.
`tests/test_learners_conformance.py` runs every check over every registered learner.
"""
from __future__ import annotations

import pickle
from collections.abc import Callable

import numpy as np

from .base import Learner
from .checks_tasks import (
    check_more_teaching_is_not_worse_closed_loop, check_no_nan_on_degenerate_streams, check_sane_on_robot_streams,
    check_unsure_answers_fade_to_the_taught_mean,
)
from .errors import LearnerInputError

Factory = Callable[..., Learner]
N_IN, N_OUT = 3, 2


def smooth_map(xs: np.ndarray) -> np.ndarray:
    """A smooth 3-input, 2-output map."""
    return np.stack([np.sin(2.0 * xs[:, 0]) + xs[:, 1], xs[:, 2] * xs[:, 0]], axis=1)


def smooth_task(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """smooth_map on n points drawn uniformly from [-1, 1]^3."""
    xs = np.random.default_rng(seed).uniform(-1.0, 1.0, (n, N_IN))
    return xs, smooth_map(xs)


def trained(make: Factory, n: int = 300, seed: int = 0) -> Learner:
    model = make(seed=seed)
    for x, y in zip(*smooth_task(n)):
        model.learn_one(x, y)
    return model


def probe_inputs() -> np.ndarray:
    return np.vstack([smooth_task(20, seed=7)[0], np.full((1, N_IN), 6.0), np.full((1, N_IN), -40.0)])


def check_predict_before_learn(make: Factory) -> None:
    model = make()
    p = model.predict_one(np.zeros(N_IN))
    assert p.y.shape == (N_OUT,) and p.y.dtype == np.float64, "prediction must be float64 (n_out,)"
    assert np.all(p.y == 0.0) and p.confidence == 0.0, "an unlearned model predicts zeros, confidence 0"
    many = model.predict_many(np.zeros((4, N_IN)))
    assert many.y.shape == (4, N_OUT) and many.confidence.shape == (4,)
    assert model.n_learned == 0 and model.size == 0


def check_inputs_not_mutated(make: Factory) -> None:
    model = make()
    xs, ys = smooth_task(50)
    x_copy, y_copy = xs.copy(), ys.copy()
    for x, y in zip(xs, ys):
        model.learn_one(x, y)
    model.learn_many(xs, ys)
    model.predict_one(xs[0])
    model.predict_many(xs)
    assert np.array_equal(xs, x_copy) and np.array_equal(ys, y_copy), "learner wrote into caller's arrays"


def check_no_aliasing(make: Factory) -> None:
    """Changing arrays after handing them over must not change the model."""
    model, reference = make(), make()
    for x, y in zip(*smooth_task(60)):
        x_mine, y_mine = x.copy(), y.copy()
        model.learn_one(x_mine, y_mine)
        reference.learn_one(x.copy(), y.copy())
        x_mine[:] = 1e6
        y_mine[:] = -1e6
    probe = smooth_task(5, seed=3)[0]
    p = model.predict_one(probe[0])
    p.y[:] = 123.0  # the caller owns what it was given
    assert np.array_equal(model.predict_many(probe).y, reference.predict_many(probe).y), "model aliases inputs"


def check_read_only_inputs(make: Factory) -> None:
    """Arrays decoded from a bus payload are often read-only; they must be accepted."""
    model = make()
    xs, ys = smooth_task(20)
    xs.setflags(write=False)
    ys.setflags(write=False)
    model.learn_one(xs[0], ys[0])
    model.learn_many(xs, ys)
    model.predict_one(xs[0])
    model.predict_many(xs)


def check_clone_independence(make: Factory) -> None:
    model = trained(make, 100)
    before = model.predict_many(probe_inputs()).y
    twin = model.clone()
    assert type(twin) is type(model) and twin.get_params() == model.get_params()
    assert twin.n_learned == 0 and twin.size == 0, "a clone starts unlearned"
    for x, y in zip(*smooth_task(50, seed=5)):
        twin.learn_one(x, -y)
    assert np.array_equal(model.predict_many(probe_inputs()).y, before), "learning a clone changed the original"


def check_pickle_round_trip(make: Factory) -> None:
    model = trained(make, 150)
    for copy in (type(model).restore(model.snapshot()), pickle.loads(pickle.dumps(model))):
        assert_same_predictions(model, copy)
        assert copy.n_learned == model.n_learned and copy.size == model.size
    copy = type(model).restore(model.snapshot())
    for x, y in zip(*smooth_task(80, seed=9)):  # and they keep learning identically
        model.learn_one(x, y)
        copy.learn_one(x, y)
    assert_same_predictions(model, copy)


def check_seeded_determinism(make: Factory) -> None:
    assert_same_predictions(trained(make, 200, seed=4), trained(make, 200, seed=4))


def check_upkeep_offline_lands_nothing(make: Factory) -> None:
    """Offline, a learner's upkeep is done in the call that needs it: nothing under way, nothing to land, and
    land_upkeep (the learner service's, between answers) leaves its answers as they were."""
    model, twin = trained(make, 200, seed=4), trained(make, 200, seed=4)
    assert model.upkeep_under_way == 0 and model.land_upkeep(0.01) == 0
    assert_same_predictions(model, twin)


BATCHES = (1, 2, 7, 40, 100)  # rows per learn_many call in check_learn_many_matches_learn_one


def check_learn_many_matches_learn_one(make: Factory) -> None:
    """learn_many of a stream in batches of 1 to 100 rows leaves a learner as learn_one of each row does,
    after every batch: the same answers (to 1e-9) and the same bookkeeping (n_learned, size, the taught
    range, the inputs shown and the taught mean that fading uses). Every learner's two paths differ: knn
    and lwpr have a batch path of their own; gp and sogp the base class's loop, whose bookkeeping is
    updated once for the batch (a `_learn_one` reading it would find it lagging); per-output hands each
    part its column (the parts' batch paths). The stream keeps going beyond what was shown, so every
    batch widens the ranges."""
    xs, ys = smooth_task(sum(BATCHES), seed=2)
    order = np.argsort(np.abs(xs).max(1))
    xs, ys = xs[order], ys[order]
    one, many = make(), make()
    start = 0
    for size in BATCHES:
        rows = slice(start, start + size)
        for x, y in zip(xs[rows], ys[rows]):
            one.learn_one(x, y)
        many.learn_many(xs[rows], ys[rows])
        start += size
        assert_same_learning(one, many, f"{start} rows learned, the last {size} by one learn_many")


def check_sources_told(make: Factory) -> None:
    """A learner that `learns_sources` (learn_one's `source`, learn_many's `sources`) answers, taught by one
    teacher named, exactly as taught without names; learns a batch with its rows' teachers as row by row; and
    refuses a source that is not a teacher's name. One that does not refuses any source (TypeError), never
    learning the pair as if told nothing."""
    xs, ys = smooth_task(120, seed=5)
    model = make()
    if not model.learns_sources:
        try:
            model.learn_one(xs[0], ys[0], source="teacher/a")
        except TypeError:
            return
        raise AssertionError("a learner that does not tell teachers apart took a source")
    named, plain = make(), make()
    for x, y in zip(xs, ys):
        named.learn_one(x, y, source="teacher/a")
        plain.learn_one(x, y)
    assert_same_predictions(named, plain)
    sources = ["teacher/a" if i % 3 else "teacher/b" for i in range(len(xs))]
    one, many = make(), make()
    for x, y, source in zip(xs, ys, sources):
        one.learn_one(x, y, source=source)
    many.learn_many(xs, ys, sources=sources)
    assert_same_learning(one, many, "a batch of two teachers' rows")
    for bad in (3, b"teacher/a", "x" * 10_000):
        try:
            make().learn_one(xs[0], ys[0], source=bad)
        except (TypeError, ValueError):
            continue
        raise AssertionError(f"source {bad!r:.40} was accepted")
    try:
        make().learn_many(xs[:3], ys[:3], sources=["teacher/a"])
    except ValueError:
        return
    raise AssertionError("learn_many took fewer sources than rows")


def bookkeeping(model: Learner) -> dict[str, np.ndarray]:
    """What the base class keeps of everything learned, by name."""
    return {"n_learned": np.array(model.n_learned), "size": np.array(model.size),
            "taught range": np.concatenate([model._taught.low, model._taught.high]),
            "inputs shown": np.concatenate([model._shown.low, model._shown.high]),
            "taught mean": model._taught_mean}


def assert_same_learning(one: Learner, many: Learner, when: str) -> None:
    """`many` (taught by learn_many) keeps what `one` (by learn_one) keeps and answers as it does."""
    kept = bookkeeping(many)
    for name, expected in bookkeeping(one).items():
        got = kept[name]
        same = np.allclose(got, expected, rtol=0.0, atol=1e-12) if name == "taught mean" else \
            np.array_equal(got, expected)
        assert same, f"{when}: learn_many's {name} is {got.tolist()}, learn_one's {expected.tolist()}"
    pa, pb = one.predict_many(probe_inputs()), many.predict_many(probe_inputs())
    gap = max(np.max(np.abs(pa.y - pb.y)), np.max(np.abs(pa.confidence - pb.confidence)))
    assert gap <= 1e-9, f"{when}: learn_many's answers differ from learn_one's by up to {gap:.3g}"


def check_memory_bounded(make: Factory) -> None:
    """A long stream from a bounded region must not make the model grow without limit."""
    model = make()
    xs, ys = smooth_task(6000, seed=11)
    model.learn_many(xs[:3000], ys[:3000])
    half = len(model.snapshot())
    model.learn_many(xs[3000:], ys[3000:])
    assert len(model.snapshot()) <= 1.25 * half + 4096, "model kept growing on a stationary stream"


def check_confidence_in_unit_interval(make: Factory) -> None:
    for model in (make(), trained(make, 200)):
        confidence = model.predict_many(probe_inputs()).confidence
        in_range = np.all(np.isfinite(confidence)) and np.all((confidence >= 0) & (confidence <= 1))
        assert in_range, f"confidence must be finite and in [0, 1], got {confidence.min()}..{confidence.max()}"
        one = model.predict_one(probe_inputs()[0]).confidence
        assert isinstance(one, float) and 0.0 <= one <= 1.0, f"predict_one confidence {one!r} not a float in [0, 1]"


def check_confidence_knows_what_it_knows(make: Factory) -> None:
    """High on the training inputs, below the paper's 'unsure' 0.25 far from them."""
    model = trained(make, 400)
    on_data = model.predict_many(smooth_task(400)[0]).confidence
    far = model.predict_many(np.array([[6.0, 6.0, 6.0], [-5.0, 4.0, -6.0]])).confidence
    assert np.median(on_data) > 0.5, f"median confidence on training data {np.median(on_data):.2f} <= 0.5"
    assert np.all(far < 0.25), f"confidence far from the data {far} not below 0.25"


def check_confidence_doubts_an_input_that_never_varied(make: Factory) -> None:
    """Taught with the last input held at 0, a 1 there is new (the orange ball after pink alone):
    the robot must ask (< 0.25) rather than drive on what it learned, and stay sure at 0."""
    xs = smooth_task(400)[0]
    xs[:, -1] = 0.0
    ys = smooth_map(xs)  # the map of the inputs as taught
    model = make()
    for x, y in zip(xs, ys):
        model.learn_one(x, y)
    moved = xs.copy()
    moved[:, -1] = 1.0
    same, new = (np.median(model.predict_many(q).confidence) for q in (xs, moved))
    assert same > 0.5, f"median confidence on the training inputs {same:.2f} <= 0.5"
    assert new < 0.25, f"median confidence with the constant input moved by 1: {new:.2f}, not below 0.25"


def check_bad_input_rejected(make: Factory) -> None:
    model = trained(make, 60)
    blob, before = model.snapshot(), model.predict_many(probe_inputs())
    good_x, good_y = np.zeros(N_IN), np.zeros(N_OUT)
    bad_xs = [np.zeros(N_IN - 1), np.zeros(N_IN + 1), np.array([0.0, np.nan, 0.0]), np.array([np.inf, 0, 0])]
    bad_ys = [np.zeros(N_OUT + 1), np.array([0.0, np.nan]), np.array([-np.inf, 0.0])]
    for bad in bad_xs:
        assert_rejected(lambda bad=bad: model.learn_one(bad, good_y))
        assert_rejected(lambda bad=bad: model.predict_one(bad))
    for bad in bad_ys:
        assert_rejected(lambda bad=bad: model.learn_one(good_x, bad))
    xs, ys = smooth_task(10)
    xs[7, 1] = np.nan
    assert_rejected(lambda: model.learn_many(xs, ys))
    assert_rejected(lambda: model.learn_many(xs[:, :2], ys))
    assert model.snapshot() == blob, "a rejected sample changed the model"
    assert np.array_equal(model.predict_many(probe_inputs()).y, before.y)


def check_error_messages(make: Factory) -> None:
    model = make()
    assert_rejected(lambda: model.learn_one(np.zeros(N_IN - 1), np.zeros(N_OUT)),
                    f"expected {N_IN} inputs, got {N_IN - 1}")
    assert_rejected(lambda: model.learn_one(np.array([0.0, 0.0, np.nan]), np.zeros(N_OUT)), "input 2 is nan")


def check_confidence_doubts_a_query_off_the_span(make: Factory) -> None:
    """Taught while input 1 moved with input 0 (a reading dragged along), a query where they part is
    off the span of the data: the robot must ask, not trust a fit that could not tell them apart."""
    rng = np.random.default_rng(6)
    xs = rng.uniform(-1, 1, (400, N_IN))
    xs[:, 1] = xs[:, 0] + rng.normal(0, 0.01, 400)
    ys = np.stack([np.sin(2 * xs[:, 0]) + xs[:, 2], xs[:, 1] * xs[:, 2]], axis=1)
    model = make()
    model.learn_many(xs, ys)
    apart = xs[:50].copy()
    apart[:, 0] = rng.choice([-0.8, 0.8], 50)
    apart[:, 1] = -apart[:, 0]
    on, off = np.median(model.predict_many(xs[:50]).confidence), np.median(model.predict_many(apart).confidence)
    assert on > 0.5, f"median confidence on the training inputs {on:.2f} <= 0.5"
    assert off < 0.25, f"median confidence with the two inputs apart {off:.2f}, not below 0.25"


def assert_rejected(call: Callable[[], object], message: str | None = None) -> None:
    try:
        call()
    except LearnerInputError as error:
        assert message is None or message in str(error), f"message {str(error)!r} lacks {message!r}"
        return
    raise AssertionError("bad input was accepted")


def assert_same_predictions(a: Learner, b: Learner) -> None:
    pa, pb = a.predict_many(probe_inputs()), b.predict_many(probe_inputs())
    assert np.array_equal(pa.y, pb.y) and np.array_equal(pa.confidence, pb.confidence), "predictions differ"


ALL_CHECKS = [
    check_predict_before_learn, check_inputs_not_mutated, check_no_aliasing, check_read_only_inputs,
    check_clone_independence, check_pickle_round_trip, check_seeded_determinism, check_upkeep_offline_lands_nothing,
    check_learn_many_matches_learn_one, check_memory_bounded, check_confidence_in_unit_interval,
    check_confidence_knows_what_it_knows, check_confidence_doubts_an_input_that_never_varied,
    check_bad_input_rejected, check_error_messages, check_sane_on_robot_streams, check_no_nan_on_degenerate_streams,
    check_confidence_doubts_a_query_off_the_span, check_unsure_answers_fade_to_the_taught_mean,
    check_more_teaching_is_not_worse_closed_loop, check_sources_told,
]


def unit_test_factory(cls: type[Learner]) -> Factory:
    """Fresh small learners of `cls` for the checks (small capacities keep them fast)."""
    params = cls._unit_test_params()
    return lambda seed=0: cls(N_IN, N_OUT, seed=seed, **params)
