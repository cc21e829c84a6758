"""A snapshot comes over the bus during a hot-swap: whatever a stranger answers there must never run
(issue 12). Only numpy arrays and the learners' own state are built from it; anything else is
refused before any of it runs, and the swapping learner learns the old one's history instead."""
import pickle

import numpy as np
import pytest

from bus_schema import PairBatch, Snapshot
from services.learners import LEARNERS, make_learner
from services.learners.base import SnapshotError


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
    assert not marker.exists()
    assert n.rejects.total == 1 and n.model.n_learned == 40 and len(n.pairs) == 40
    assert "training on 40 pairs" in caplog.text
