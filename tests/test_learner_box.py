"""The learner box on a fake bus: a gap in the training pairs filled from the arbitrator's recent pairs,
pairs it no longer has counted lost, partial pairs, clipped proposals, and the pair log holding every
pair learned, in order. Epochs and hostile seqs: tests/test_learner_box_hostile.py."""
import numpy as np

from bus_schema import InstanceKeys, Input, PairBatch, Proposal, Status, TrainingPair, decode, encode
from bus_schema.spaces import Box
from services.boxes.learner import LearnerNode
from services.learners import make_learner
from services.pairlog import PairLog
from tests.fakebus import FakeStop, fake_box

KEYS = InstanceKeys("main")


class Recent:
    """The arbitrator's recent pairs, answering dl/<i>/train/recent?from=..;to=.. as it does."""

    def __init__(self, *pairs: TrainingPair):
        self.pairs = {(p.epoch, p.seq): p for p in pairs}

    def __call__(self, parameters: dict):
        first, last = int(parameters["from"]), int(parameters["to"])
        rows = sorted((p for (_, seq), p in self.pairs.items() if first <= seq <= last), key=lambda p: p.seq)
        if not rows:
            return None
        return encode(PairBatch(rows[0].epoch, rows[0].seq, np.array([p.x for p in rows]),
                                np.array([p.y for p in rows]), np.ones((len(rows), 1))))


def pair(seq: int, epoch: str = "e1", mask=None) -> TrainingPair:
    return TrainingPair(epoch, seq, seq, np.array([0.1 * seq, -0.1 * seq]), np.array([0.05 * seq]), "teacher/t", mask)


def node(*recent: TrainingPair, model=None):
    box = fake_box("learner", "student")
    box.session.answer(KEYS.train_recent, Recent(*recent))
    learner = LearnerNode(box, model or make_learner("knn", 2, 1), PairLog(2, 1), Box((-1.0,), (1.0,)))
    return learner, box.session


def test_a_gap_is_filled_from_the_arbitrators_recent_pairs():
    learner, bus = node(*(pair(s) for s in range(1, 6)))
    for seq in (1, 2, 5):
        learner.on_pair(pair(seq))
    assert (learner.seq, learner.counts["gap_filled"], learner.counts["pairs_lost"]) == (5, 2, 0)
    assert bus.asked == [f"{KEYS.train_recent}?from=3;to=4"]
    x, y, *_ = learner.pairs.history()
    assert learner.model.n_learned == 5 and x[:, 0].round(3).tolist() == [0.1, 0.2, 0.3, 0.4, 0.5]


def test_pairs_the_arbitrator_no_longer_has_are_counted_lost_and_learning_goes_on():
    learner, _ = node()  # its recent pairs have rolled past 3 and 4
    for seq in (1, 2, 5, 6):
        learner.on_pair(pair(seq))
    assert (learner.seq, learner.counts["pairs_lost"], learner.counts["learned"]) == (6, 2, 4)
    assert len(learner.pairs) == learner.model.n_learned == 4


def test_a_partial_pair_trains_only_its_outputs_where_the_learner_can_and_is_counted_where_it_cannot():
    learner, _ = node()
    learner.on_pair(pair(1, mask=np.array([0.0])))
    assert learner.counts["partial_pairs_learned_whole"] == 1  # knn takes no mask
    masked, _ = node(model=make_learner("per-output", 2, 1, base="knn"))
    masked.on_pair(pair(1, mask=np.array([0.0])))
    assert masked.counts["partial_pairs_learned_whole"] == 0


def test_proposals_are_clipped_to_the_output_space():
    learner, bus = node(model=make_learner("knn", 2, 1))
    learner.on_pair(TrainingPair("e1", 1, 1, np.zeros(2), np.array([5.0]), "teacher/t", None))
    learner.answer(type("In", (), {"tick": 7, "x": np.zeros(2)})())
    (payload,) = bus.on(KEYS.proposal("learner", "student"))
    proposal = decode(Proposal, payload, KEYS.proposal("learner", "student"))
    assert proposal.tick == 7 and proposal.y.tolist() == [1.0] and learner.counts["clipped"] == 1


def test_its_loop_answers_the_newest_input_of_a_batch_before_learning_the_batchs_pairs():
    learner, bus = node()
    runtime = learner.box
    runtime.subscribe(KEYS.train, "train")  # as its main declares them
    runtime.subscribe(KEYS.input, "input")
    for tick in (1, 2):
        bus.deliver(KEYS.input, encode(Input(tick, 0.0, np.zeros(2))))
    bus.deliver(KEYS.train, encode(pair(1)))
    bus.deliver(KEYS.input, b"\xc1")
    runtime.stop = FakeStop(1)
    for batch in runtime.batches(0.0, learner.report):
        learner.handle(batch)
    [answer] = [decode(Proposal, p, "k") for p in bus.on(KEYS.proposal("learner", "student"))]
    assert answer.tick == 2 and answer.learned == 0, "answered before the batch's pair was learned"
    assert learner.seq == 1 and learner.model.n_learned == 1
    [status] = [decode(Status, p, "k") for p in bus.on(KEYS.status("learner", "student"))]
    assert status.counters["learned"] == 1 and status.counters["seq"] == 1 and status.counters["rejected"] == 1
