"""The arbitrator's recent pairs (gap filling): a fixed ring that answers a seq range exactly, past
wrap-around, and whose memory is all taken at the start (an all-day run found the old store of pair
objects growing by about 40 MB an hour: benchmarks/soak.py)."""
import tracemalloc

import numpy as np
import pytest
import zenoh

from bus_schema import PairBatch, decode
from bus_schema.teachers import sources_of
from services.arbitration.recent_pairs import RecentPairs
from services.arbitration.strategies import TeacherFirst
from services.boxes.arbitrator import Arbitrator
from tests.fakebus import fake_box
from tests.test_arbitrator_box import DEADLINE, KEYS, SPACES, Bench


def filled(capacity, n):
    ring = RecentPairs(capacity, 2, 3)
    for seq in range(1, n + 1):
        ring.append(seq, np.array([seq, -seq], float), np.full(3, seq * 0.5), None if seq % 2 else np.array([1, 0, 1]))
    return ring


def test_a_range_is_answered_row_for_row_with_its_masks():
    first, xs, ys, masks, _, _ = filled(8, 5).rows(2, 4)
    assert first == 2 and xs[:, 0].tolist() == [2, 3, 4] and ys[:, 0].tolist() == [1.0, 1.5, 2.0]
    assert masks.tolist() == [[1, 0, 1], [1, 1, 1], [1, 0, 1]] and masks.dtype == np.float64


def test_past_its_capacity_the_oldest_are_gone_and_the_rest_in_order():
    ring = filled(4, 10)
    assert len(ring) == 4 and ring.first_seq == 7
    first, xs, *_ = ring.rows(1, 100)
    assert first == 7 and xs[:, 0].tolist() == [7, 8, 9, 10]
    first, xs, ys, masks, _, teacher_of = ring.rows(1, 6)  # rolled past: none, named from what was asked
    assert first == 1 and xs.shape == (0, 2) and ys.shape == masks.shape == (0, 3) and teacher_of == b""


def test_each_row_says_who_taught_it():
    ring = RecentPairs(4, 2, 3)
    for seq, source in enumerate(["teacher/a", "teacher/b", "teacher/a", "", "teacher/c"], start=1):
        ring.append(seq, np.zeros(2), np.zeros(3), None, source)
    first, *_, teachers, teacher_of = ring.rows(1, 9)
    assert first == 2 and sources_of(teachers, teacher_of) == ["teacher/b", "teacher/a", "unnamed", "teacher/c"]


def test_a_seq_out_of_order_is_refused_and_changes_nothing():
    ring = filled(4, 3)
    with pytest.raises(ValueError, match="does not follow"):
        ring.append(5, np.zeros(2), np.zeros(3), None)
    assert ring.last_seq == 3 and ring.rows(1, 3)[1][:, 0].tolist() == [1, 2, 3]


def test_its_memory_is_taken_whole_at_the_start():
    ring = RecentPairs(65536, 18, 18)  # mirroring's: every page written now, none as pairs come
    assert ring._x.nbytes + ring._y.nbytes + ring._mask.nbytes == 65536 * (18 * 8 * 2 + 18)
    assert np.isnan(ring._x).all()


class Query:
    def __init__(self, parameters):
        self.key_expr, self.parameters = KEYS.train_recent, zenoh.Parameters(parameters)
        self.replies, self.errors = [], []

    def reply(self, key, payload):
        self.replies.append(decode(PairBatch, payload, key, {"x": 2, "y": 2, "mask": 2}))

    def reply_err(self, payload):
        self.errors.append(payload)


def test_the_arbitrator_answers_gap_queries_from_its_ring():
    b = Bench()
    for seq in range(1, 6):
        b.arb.publish_pair(seq, np.array([0.1 * seq, 0.0]), np.array([0.2, -0.2]), "teacher/t",
                           None if seq != 3 else np.array([0.0, 1.0]))
    q = Query("from=2;to=3")
    b.arb.on_recent_query(q)
    batch = q.replies[0]
    assert batch.epoch == b.arb.epoch and batch.first_seq == 2 and batch.x[:, 0].tolist() == [0.2, 0.30000000000000004]
    assert batch.mask.tolist() == [[1, 1], [0, 1]]
    bad = Query("from=two")
    b.arb.on_recent_query(bad)
    assert bad.errors and not bad.replies and b.arb.rejects.total == 1



class Nowhere:
    def put(self, payload):
        pass


def test_pairs_published_keep_no_memory_beyond_the_ring():
    """The regression: held as pair objects, 5,000 two-input pairs kept 790 kB more; in the ring, nothing."""
    arb = Arbitrator(fake_box("arbitrator"), SPACES, TeacherFirst(), DEADLINE, None, "teacher", 65536)
    arb.train_pub = Nowhere()  # the fake bus keeps what is put; the bus does not
    x, y = np.array([0.1, 0.2]), np.array([0.3, -0.3])
    arb.publish_pair(1, x, y, "teacher/t")
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        for tick in range(2, 5002):
            arb.publish_pair(tick, x, y, "teacher/t")
        kept = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    assert kept < 50_000, f"5,000 pairs kept {kept} bytes"
