"""The input envelope: doubt beyond experience for learners whose kernels cannot see it."""
import pickle

import numpy as np
import pytest

from services.learners import KNN, SOGP
from services.learners.novelty import EXPERIENCED_SDS, InputEnvelope


def test_batches_merge_to_the_whole_stream_mean_and_spread():
    xs = np.random.default_rng(0).normal([1.0, -2.0, 0.0], [0.5, 3.0, 1e-3], (257, 3))
    envelope = InputEnvelope(3)
    for batch in np.split(xs, [1, 50, 51, 200]):  # uneven batches, two of a single row
        envelope.learn(batch)
    assert envelope.count == 257
    np.testing.assert_allclose(envelope.mean, xs.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(envelope.sum_sq / envelope.count, xs.var(axis=0), rtol=1e-9)


def test_one_row_at_a_time_gives_numpys_numbers_to_the_bit():
    """The compiled one-row merge is the numpy one it replaced: delta delta' count / total, delta / total."""
    rows = np.random.default_rng(3).normal(size=(200, 7)) * [1, 10, 0.1, 1, 1, 5, 1e-3]
    envelope, mean, scatter = InputEnvelope(7), np.zeros(7), np.zeros((7, 7))
    for count, row in enumerate(rows):
        envelope.learn(row[None, :])
        total = count + 1
        delta = row - mean
        scatter += np.outer(delta, delta) * (count / total)
        mean += delta / total
    assert envelope.count == 200
    assert np.array_equal(envelope.mean, mean) and np.array_equal(envelope.scatter, scatter)


def test_discount_is_one_within_experience_and_falls_beyond_it():
    envelope = InputEnvelope(2)
    assert envelope.beyond_inputs(np.ones((1, 2)), 0.25).tolist() == [1.0]  # nothing learned: no opinion
    envelope.learn(np.array([[-1.0, 0.0], [1.0, 0.0]]))  # sd 1 along the first input, 0 along the second
    inside, edge, beyond, off = envelope.beyond_inputs(np.array([[2.9, 0.0], [EXPERIENCED_SDS, 0.0], [3.25, 0.0],
                                                            [0.0, 0.25]]), 0.25)
    assert inside == edge == 1.0
    assert beyond == pytest.approx(np.exp(-0.5)) and off == pytest.approx(np.exp(-0.5))
    assert envelope.beyond_inputs(np.array([[0.0, 5.0]]), 0.0).tolist() == [1.0]  # scale 0: off


def test_beyond_span_sees_two_inputs_that_never_parted():
    rng = np.random.default_rng(1)
    line = rng.uniform(-1.0, 1.0, 500)
    envelope = InputEnvelope(2)
    envelope.learn(np.column_stack([line, line + rng.normal(0.0, 0.01, 500)]))
    along, apart = envelope.beyond_span(np.array([[0.9, 0.9], [0.5, -0.5]]), 0.25)
    assert along == 1.0 and apart < 0.05
    # each input alone stays within its own range, so the axis-aligned form cannot tell
    assert envelope.beyond_inputs(np.array([[0.5, -0.5]]), 0.25).tolist() == [1.0]


def test_snapshot_of_an_envelope_that_kept_only_spreads_restores():
    envelope = InputEnvelope(2)
    envelope.learn(np.array([[-1.0, 0.0], [1.0, 2.0]]))
    state = dict(envelope.__dict__, sum_sq=envelope.sum_sq)
    del state["scatter"], state["_axes"]
    old = InputEnvelope.__new__(InputEnvelope)
    old.__setstate__(state)
    np.testing.assert_allclose(old.sum_sq, envelope.sum_sq)
    assert old.beyond_span(np.array([[0.0, 1.0]]), 0.25).tolist() == [1.0]


@pytest.mark.parametrize("cls", [SOGP, KNN])
def test_snapshot_from_before_the_envelope_restores_and_predicts(cls):
    model = cls(2, 1)
    model.learn_one([0.1, 0.0], [1.0])
    state = dict(model.__getstate__())
    del state["_envelope"], state["novelty_scale"]
    old = cls.__new__(cls)
    old.__setstate__(pickle.loads(pickle.dumps(state)))
    assert old.novelty_scale == 0.25
    np.testing.assert_allclose(old.predict_one([0.1, 5.0]).y, model.predict_one([0.1, 5.0]).y)
    old.learn_one([0.2, 0.0], [1.0])  # and it learns on, its envelope from now


@pytest.mark.parametrize("cls", [SOGP, KNN])
def test_invalid_novelty_scale_is_named(cls):
    with pytest.raises(ValueError, match="novelty_scale"):
        cls(2, 1, novelty_scale=-1.0)
