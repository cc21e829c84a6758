"""A snapshot comes over the bus during a hot-swap: whatever a stranger answers there must never run
(issue 12). Only numpy arrays and the learners' own state are built from it; anything else is
refused before any of it runs, and the swapping learner learns the old one's history instead.
Snapshots are data (services.learners.snapshot_codec): a pickle is not one, whatever it names."""
import pickle

import msgpack
import numpy as np
import pytest

from bus_schema import PairBatch, Snapshot
from services.learners import LEARNERS, make_learner
from services.learners.base import SnapshotError
from services.learners.snapshot_codec import encode_value


class Planted:
    """A pickle that, loaded, creates a file: what a stranger's code could do instead."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return open, (self.path, "w")


def hostile_blobs(marker):
    return [pickle.dumps(Planted(marker)), pickle.dumps({"model": Planted(marker)}),
            pickle.dumps([np.zeros(3), Planted(marker)]), b"not a pickle at all", b""]


@pytest.mark.parametrize("name", sorted(LEARNERS))
def test_restore_refuses_a_pickle_that_names_anything_but_learner_state(tmp_path, name):
    marker = tmp_path / "ran"
    for blob in hostile_blobs(marker):
        with pytest.raises(SnapshotError):
            LEARNERS[name].restore(blob)
    assert not marker.exists()


def packed(state, name="KNN"):
    """A snapshot in the data format, its learner's state as given."""
    obj = msgpack.ExtType(2, msgpack.packb([name, state], use_bin_type=True, default=encode_value))
    return msgpack.packb({"format": "dogged-learner-snapshot", "version": 1, "state": obj}, use_bin_type=True)


def array(dtype, shape, raw):
    return msgpack.ExtType(1, msgpack.packb([dtype, shape, raw], use_bin_type=True))


def knn_state(**changes):
    model = make_learner("knn", 2, 1)
    model.learn_many(np.eye(2), np.ones((2, 1)))
    state = model.__getstate__()
    state = {k: v for k, v in state.items() if not hasattr(v, "__dict__")}  # its plain values
    state.update(changes)
    return state


@pytest.mark.parametrize("blob, reason", [
    (packed({}, name="Popen"), "not 'Popen'"),
    (packed({"n_in": 2, "n_out": 1, "x": array("|O", [1], b"\x00" * 8)}), "dtype"),
    (packed({"n_in": 2, "n_out": 1, "x": array("<f8", [3], b"\x00" * 8)}), "does not match"),
    (packed({"n_in": 2, "n_out": 1, "x": array("<f8", [-1], b"")}), "shape"),
    (packed(knn_state(n_in=10 ** 9)), "n_in must be an integer"),
    (packed(knn_state(n_out=True)), "n_out must be an integer"),
    (packed(knn_state(_xs=np.zeros(0).tobytes())), "does not answer"),
    (msgpack.packb({"format": "dogged-learner-snapshot", "version": 2, "state": None}), "version 2"),
    (msgpack.packb({"format": "dogged-learner-snapshot", "version": 1, "state": msgpack.ExtType(9, b"")}), "extension"),
    (msgpack.packb([1, 2, 3]), "no 'dogged-learner-snapshot' header"),
])
def test_restore_refuses_well_formed_data_that_is_not_a_sane_learner(blob, reason):
    with pytest.raises(SnapshotError, match=reason):
        LEARNERS["knn"].restore(blob)


@pytest.mark.parametrize("name", sorted(LEARNERS))
def test_a_snapshot_is_data_that_restores_the_same_answers(name):
    kw = {"base": "gp"} if name == "per-output" else {}
    model = make_learner(name, 3, 2, **kw)
    xs = np.random.default_rng(1).uniform(-1, 1, (50, 3))
    model.learn_many(xs, np.sin(xs[:, :2]))
    blob = model.snapshot()
    with pytest.raises((pickle.UnpicklingError, ValueError)):
        pickle.loads(blob)  # not a pickle at all
    copy = LEARNERS[name].restore(blob)
    np.testing.assert_array_equal(copy.predict_many(xs).y, model.predict_many(xs).y)


def test_restore_refuses_another_learners_snapshot():
    with pytest.raises(SnapshotError, match="holds a KNN, not a GP"):
        LEARNERS["gp"].restore(make_learner("knn", 2, 1).snapshot())


def test_a_swap_answered_with_a_hostile_snapshot_learns_the_history_and_runs_nothing(tmp_path, caplog):
    from tests.test_learner_box_hostile import node

    marker = tmp_path / "ran"
    rng = np.random.default_rng(0)
    xs, ys = rng.uniform(-1, 1, (40, 2)), rng.uniform(-1, 1, (40, 1))
    answers = {"snapshot": Snapshot("KNN", "e1", 40, 40, pickle.dumps(Planted(marker))),
               "history": PairBatch("e1", 1, xs, ys, np.ones_like(ys))}
    n = node()  # the learner service's logic, its queries answered here
    n.query = lambda key, cls, parameters="", timeout=5.0: answers[key.rsplit("/", 1)[-1]]
    with caplog.at_level("INFO"):
        assert n.warm_from("old")
        while n.backlog:  # learned between answers (services.boxes.learner.catch_up)
            n.catch_up(1.0)
    assert not marker.exists()
    assert n.rejects.total == 1 and n.model.n_learned == 40 and len(n.pairs) == 40
    assert "training on 40 pairs" in caplog.text


def test_a_swap_whose_old_learner_is_restarting_waits_for_it_and_warms(monkeypatch):
    """(issue 31's soak: the old learner SIGKILLed mid-swap; its replacement started cold, and every pair
    the arbitrator no longer held, those of its earlier runs, was gone with it)"""
    from services.boxes import learner_warming
    from tests.test_learner_box_hostile import node

    monkeypatch.setattr(learner_warming, "ASK_AGAIN_S", 0.01)
    rng = np.random.default_rng(0)
    xs, ys = rng.uniform(-1, 1, (40, 2)), rng.uniform(-1, 1, (40, 1))
    answers = {"snapshot": Snapshot("SOGP", "e1", 40, 40, b"another class: learn the history"),
               "history": PairBatch("e1", 1, xs, ys, np.ones_like(ys))}
    asked = []

    def query(key, cls, parameters="", timeout=5.0):
        asked.append(key)
        return answers[key.rsplit("/", 1)[-1]] if len(asked) > 5 else None  # down for its first five asks
    n = node()
    n.query = query
    assert n.warm_from("old")
    while n.backlog:
        n.catch_up(1.0)
    assert n.model.n_learned == 40 and len(n.pairs) == 40 and n.counts["warmed"] == 40
