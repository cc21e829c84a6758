"""Valid-but-hostile values at the learner service (issue 12): a training pair whose seq jumps by a
billion, and history queries with bad parameters. Rejected, counted, and learning goes on."""
import math

import numpy as np
import zenoh

from bus_schema import TrainingPair
from bus_schema.spaces import Box
from services.boxes.learner import LearnerNode, history_query_problem
from services.learners import make_learner
from services.pairlog import PairLog
from tests.fakebus import fake_box
from tests.test_learner_box import Recent


def node(recent: dict | None = None) -> LearnerNode:
    """The learner box on a fake bus: `recent` are the arbitrator's pairs by seq."""
    box = fake_box("learner", "learner")
    box.session.answer(box.keys.train_recent, Recent(*(recent or {}).values()))
    return LearnerNode(box, make_learner("knn", 2, 1), PairLog(2, 1), Box((-1.0,), (1.0,)))


def pair(seq, epoch="e1"):
    return TrainingPair(epoch, seq, seq, np.array([0.1 * seq % 1, 0.2]), np.array([0.5]), "teacher/t", None)


def test_a_seq_that_jumps_by_a_billion_is_rejected_and_learning_goes_on():
    n = node()
    for seq in (1, 2, 3):
        n.on_pair(pair(seq))
    n.on_pair(pair(3 + 10 ** 9))
    assert n.seq == 3 and n.rejects.total == 1
    n.on_pair(pair(4))
    assert n.seq == 4 and n.counts["learned"] == 4 and n.counts["duplicates"] == 0


def test_a_long_jump_the_arbitrator_confirms_is_taken():
    far = pair(100_000)
    n = node(recent={100_000: far})
    n.on_pair(pair(1))
    n.on_pair(far)
    assert n.seq == 100_000 and n.rejects.total == 0 and n.counts["pairs_lost"] == 100_000 - 2


def test_a_pair_in_an_epoch_the_arbitrator_does_not_have_is_rejected():
    n = node()
    for seq in (1, 2):
        n.on_pair(pair(seq))
    n._last_confirm = -math.inf
    n.on_pair(pair(1, epoch="stranger"))  # learned, it would reset the seqs and teach a stranger's pair
    assert n.epoch == "e1" and n.seq == 2 and n.rejects.total == 1 and n.counts["learned"] == 2
    n.on_pair(pair(3))
    assert n.seq == 3 and n.counts["learned"] == 3


def test_a_new_epoch_the_arbitrator_confirms_begins():
    restarted = pair(1, epoch="e2")
    n = node(recent={1: restarted})
    n.on_pair(pair(1))
    n.on_pair(restarted)
    assert n.epoch == "e2" and n.seq == 1 and n.rejects.total == 0 and n.counts["learned"] == 2


class Query:
    def __init__(self, key, parameters):
        self.key_expr, self.parameters, self.errors, self.replies = key, zenoh.Parameters(parameters), [], []

    def reply_err(self, payload):
        self.errors.append(payload)

    def reply(self, key, payload):
        self.replies.append(payload)


def test_history_queries_with_bad_parameters_get_an_error_answer():
    n = node()
    for seq in (1, 2):
        n.on_pair(pair(seq))
    for params in ("upto=abc", "upto=-1", "upto=99999999999999999999", "epoch=" + "x" * 65, "evil=1"):
        q = Query(n.keys.history("learner"), params)
        n.on_query(q)
        assert q.errors and not q.replies, params
    good = Query(n.keys.history("learner"), "epoch=e1;upto=1")
    n.on_query(good)
    assert good.replies and not good.errors and n.rejects.total == 5


def test_history_query_problems_name_the_parameter():
    assert history_query_problem(zenoh.Parameters("upto=abc")).startswith("history: upto must be")
    assert "unknown parameter 'x'" in history_query_problem(zenoh.Parameters("x=1"))
    assert history_query_problem(zenoh.Parameters("epoch=abc;upto=12")) == ""
