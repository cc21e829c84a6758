"""Spaces answered with other dimensions (issue 12): a restarted learner once took a stranger's answer,
rejected every input, and truncated its --state-dir pair log to 0 bytes. Now answers that disagree are
not trusted, and a pair log of other dimensions is refused and kept byte for byte."""
import logging
import threading

import numpy as np
import pytest
import zenoh

from bus_schema import InstanceKeys, PairBatch, SpacesMessage, TrainingPair, encode
from bus_schema.spaces import Box, Spaces
from rigs.harness import wait_until
from services.bus.queries import fetch_spaces
from services.bus.config import zenoh_config
from services.pairlog import PairLog, PairLogError


def saved_log(path, n=5):
    log = PairLog(2, 1, path)
    log.replay_file()
    for i in range(n):
        x, y = np.full(2, i, float), np.full(1, -i, float)
        log.append(TrainingPair("e", i + 1, i, x, y, "teacher/t"))
    log.close()
    return path.read_bytes()


def test_a_pair_log_of_other_dimensions_is_refused_and_kept(tmp_path):
    path = tmp_path / "learner.pairs"
    before = saved_log(path)
    with pytest.raises(PairLogError, match="record 1 is not a 3 -> 1 training pair"):
        PairLog(3, 1, path).replay_file()
    assert path.read_bytes() == before
    assert [p.seq for p in PairLog(2, 1, path).replay_file()] == [1, 2, 3, 4, 5]


def test_garbage_inside_a_pair_log_is_refused_and_kept(tmp_path):
    path = tmp_path / "learner.pairs"
    saved_log(path)
    with open(path, "ab") as f:
        f.write(b"\xc1" + encode(TrainingPair("e", 6, 6, np.zeros(2), np.zeros(1), "teacher/t")))
    before = path.read_bytes()
    with pytest.raises(PairLogError, match="not a pair log after record 5"):
        PairLog(2, 1, path).replay_file()
    assert path.read_bytes() == before


def wait_answerers(session: zenoh.Session, key: str, count: int) -> None:
    """Until exactly `count` queryables answer on `key`: declared and routed, or gone."""
    def answering() -> int:
        return sum(r.ok is not None for r in session.get(key, timeout=1.0, target=zenoh.QueryTarget.ALL,
                                                         consolidation=zenoh.ConsolidationMode.NONE))
    wait_until(lambda: answering() == count, 10, f"{count} answerers on {key}")


def answer_spaces(endpoint, keys, spaces: Spaces, stop: threading.Event):
    payload = encode(SpacesMessage(spaces.to_dict()))
    with zenoh.open(zenoh_config(connect=[endpoint], mode="client")) as session:
        session.declare_queryable(keys.spaces, lambda query: query.reply(keys.spaces, payload))
        stop.wait()


def spaces(n_in):
    return Spaces(Box.uniform(n_in, -1.0, 1.0), Box.uniform(2, -1.0, 1.0))


def test_spaces_that_two_answerers_disagree_on_are_not_trusted(router, caplog):
    keys, stops = InstanceKeys("main"), [threading.Event(), threading.Event()]
    threads = [threading.Thread(target=answer_spaces, args=(router, keys, spaces(n), stop), daemon=True)
               for n, stop in zip((18, 3), stops)]
    for t in threads:
        t.start()
    log = logging.getLogger("test.spaces")
    with zenoh.open(zenoh_config(connect=[router], mode="client")) as session:
        wait_answerers(session, keys.spaces, 2)
        with caplog.at_level("ERROR"):
            assert fetch_spaces(session, keys.spaces, False, log, timeout=2.5) is None
        assert "disagree (18 -> 2; 3 -> 2)" in caplog.text
        stops[1].set()  # the stranger leaves: the platform's answer stands alone
        threads[1].join(5)
        wait_answerers(session, keys.spaces, 1)
        got = fetch_spaces(session, keys.spaces, False, log, timeout=5.0)
        assert got is not None and got.input.dims == 18
    stops[0].set()
    threads[0].join(5)


def answer(endpoint, key, payload: bytes, stop: threading.Event):
    with zenoh.open(zenoh_config(connect=[endpoint], mode="client")) as session:
        session.declare_queryable(key, lambda query: query.reply(key, payload))
        stop.wait()


def test_a_learner_trusts_no_answer_that_a_second_answerer_contradicts(router):
    """A stranger answering the arbitrator's recent pairs could confirm a hostile seq jump; answering a
    snapshot or a history, it could hand a swapping learner a poisoned model (issue 12)."""
    from services.boxes.learner import LearnerNode
    from tests.test_learner_box_hostile import node

    keys = InstanceKeys("main")
    batch = PairBatch("e1", 5, np.zeros((1, 2)), np.zeros((1, 1)), np.ones((1, 1)))
    forged = PairBatch("e1", 5, np.ones((1, 2)), np.ones((1, 1)), np.ones((1, 1)))
    stops = [threading.Event(), threading.Event()]
    threads = [threading.Thread(target=answer, args=(router, keys.train_recent, encode(b), stop), daemon=True)
               for b, stop in zip((batch, forged), stops)]
    for t in threads:
        t.start()
    with zenoh.open(zenoh_config(connect=[router], mode="client")) as session:
        n = node()
        n.session, n.query = session, LearnerNode.query.__get__(n)
        wait_answerers(session, keys.train_recent, 2)
        assert n.query(keys.train_recent, PairBatch, "from=5;to=5", timeout=2.0) is None
        assert n.rejects.total == 1
        stops[1].set()
        threads[1].join(5)
        wait_answerers(session, keys.train_recent, 1)
        got = n.query(keys.train_recent, PairBatch, "from=5;to=5", timeout=2.0)
        assert got is not None and got.x.tolist() == [[0.0, 0.0]] and n.rejects.total == 1
    stops[0].set()
    threads[0].join(5)
