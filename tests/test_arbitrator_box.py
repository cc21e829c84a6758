"""The arbitrator box on a fake bus (payloads in, publications out): deadlines and members not waited
for, the learner fallback, partial teachers' masks, clipping; and the in-process Algorithm 2
(services.experiments.loop.tick) deciding exactly as the box does."""
import numpy as np
import zenoh

from bus_schema import Command, InstanceKeys, Input, Proposal, SelectLearner, TrainingPair, decode, encode
from bus_schema.spaces import Box, Spaces
from services.arbitration.strategies import TeacherFirst
from services.boxes.arbitrator import MISSES_BEFORE_IGNORED, Arbitrator
from services.experiments.loop import tick as in_process_tick
from services.learners import make_learner
from tests.fakebus import fake_box

KEYS = InstanceKeys("main")
SPACES = Spaces(Box((-1.0, -1.0), (1.0, 1.0)), Box((-0.5, -0.5), (0.5, 0.5)))
DEADLINE = 0.02


class Bench:
    """An Arbitrator on a fake bus, with a clock the test moves."""

    def __init__(self, learner=None):
        box, self.now = fake_box("arbitrator", "arbitrator"), 100.0
        self.bus, self.arb = box.session, Arbitrator(box, SPACES, TeacherFirst(), DEADLINE, learner, "teacher", 64)

    def alive(self, role, name, on=True):
        self.arb.on_alive(KEYS.alive(role, name), zenoh.SampleKind.PUT if on else zenoh.SampleKind.DELETE)

    def input(self, tick, x=(0.1, 0.2)):
        self.arb.on_input(KEYS.input, encode(Input(tick, 0.0, np.array(x, float))), self.now)

    def propose(self, role, name, tick, y, confidence=1.0, mask=None):
        p = Proposal(tick, f"{role}/{name}", None if y is None else np.array(y, float), confidence,
                     None if mask is None else np.array(mask, float))
        self.arb.on_proposal(KEYS.proposal(role, name), encode(p), self.now)

    def decide(self, later=0.0):
        self.now += later
        self.arb.decide_ready(self.now)

    def commands(self):
        return [decode(Command, p, KEYS.command) for p in self.bus.on(KEYS.command)]

    def pairs(self):
        return [decode(TrainingPair, p, KEYS.train) for p in self.bus.on(KEYS.train)]


def test_a_tick_waits_for_the_learner_until_its_deadline_then_a_silent_member_is_not_waited_for():
    b = Bench()
    b.alive("learner", "student")
    for t in range(1, MISSES_BEFORE_IGNORED + 1):
        b.input(t)
        b.decide()
        assert len(b.commands()) == t - 1, "decided before the deadline, without the learner"
        b.decide(later=DEADLINE)
        assert b.commands()[-1].tick == t and b.commands()[-1].source == "hold"
    assert b.arb.silent() == ["learner/student"] and b.arb.counts["deadline_misses"] == MISSES_BEFORE_IGNORED
    b.input(99)
    b.decide()
    assert b.commands()[-1].tick == 99, "no longer waited for: decided at once"
    assert b.arb.counts["without_learner"] == MISSES_BEFORE_IGNORED + 1, "each tick so far went on without it"
    assert b.arb.counts["deadline_misses"] == MISSES_BEFORE_IGNORED, "the last one without missing a deadline"
    b.propose("learner", "student", 100, (0.1, 0.1))
    assert b.arb.silent() == [], "it answers: waited for again"


def test_the_selected_learner_gone_the_longest_lived_serves():
    b = Bench(learner="chosen")
    for name in ("old", "chosen", "young"):
        b.alive("learner", name)
    assert b.arb.active_learner() == "chosen"
    b.alive("learner", "chosen", on=False)
    assert b.arb.active_learner() == "old"
    b.input(1)
    b.propose("learner", "young", 1, (0.4, 0.4), 0.9)
    b.propose("learner", "old", 1, (0.2, 0.2), 0.9)
    b.decide()
    assert b.commands()[-1].source == "learner/old" and b.commands()[-1].mode == "student"
    for name in ("old", "young"):
        b.alive("learner", name, on=False)
    b.input(2)
    b.decide()
    held = b.commands()[-1]
    assert (held.source, held.mode, held.y.tolist()) == ("hold", "unsure", [0.2, 0.2]), "the last command held"


def test_partial_teachers_merge_and_the_pair_says_what_was_taught():
    b = Bench()
    b.alive("learner", "student")
    b.alive("teaching", "pan")
    b.input(1)
    b.propose("learner", "student", 1, (0.3, 0.3), 0.9)
    b.propose("teacher", "pan", 1, (-0.2, 0.0), 1.0, mask=(1, 0))
    b.decide()
    command, pair = b.commands()[-1], b.pairs()[-1]
    assert command.mode == "teacher" and command.y.tolist() == [-0.2, 0.3], "untaught output: the student's"
    assert pair.mask.tolist() == [1.0, 0.0] and pair.y.tolist() == [-0.2, 0.3]
    b.alive("teaching", "tilt")
    b.input(2)
    b.propose("learner", "student", 2, (0.3, 0.3), 0.9)
    b.propose("teacher", "pan", 2, (-0.2, 0.0), 1.0, mask=(1, 0))
    b.propose("teacher", "tilt", 2, (0.0, 0.1), 1.0, mask=(0, 1))
    b.decide()
    assert b.commands()[-1].y.tolist() == [-0.2, 0.1] and b.pairs()[-1].mask is None, "both taught: a whole pair"


def test_a_proposal_from_a_teacher_not_switched_on_is_counted_and_unused():
    b = Bench()
    b.alive("learner", "student")
    b.input(1)
    b.propose("learner", "student", 1, (0.1, 0.1), 0.9)
    b.propose("teacher", "stranger", 1, (0.4, 0.4), 1.0)
    b.decide(later=DEADLINE)
    assert b.commands()[-1].source == "learner/student" and b.pairs() == []
    assert b.arb.counts["teacher_proposals_without_token"] == 1


def test_commands_and_pairs_are_clipped_to_the_output_space_and_the_in_process_loop_agrees():
    """One Algorithm 2: the same proposals give the same command and training pair through the box
    and through services.experiments.loop.tick."""
    b = Bench()
    b.alive("learner", "student")
    b.alive("teaching", "wild")
    student = make_learner("knn", 2, 2)
    x = np.array([0.1, 0.2])
    predicted = student.predict_one(x)
    b.input(1, x)
    b.propose("learner", "student", 1, predicted.y, predicted.confidence)
    b.propose("teacher", "wild", 1, (3.0, -0.25), 1.0)
    b.decide()
    command, pair = b.commands()[-1], b.pairs()[-1]
    assert command.y.tolist() == [0.5, -0.25] and pair.y.tolist() == [0.5, -0.25]
    assert b.arb.counts["clipped_commands"] == 1

    def wild(_x):
        return np.array([3.0, -0.25]), 1.0
    decision, _, _ = in_process_tick(x, [("teacher/wild", wild)], student, output_space=SPACES.output)
    assert (decision.y.tolist(), decision.mode, decision.source) == (command.y.tolist(), command.mode, command.source)
    assert student.n_learned == 1 and np.allclose(student.predict_one(x).y, pair.y)


def test_a_selection_said_again_until_confirmed_is_one_swap():
    """(`dogged swap` says the selection again until the arbitrator's status confirms it: a put can be lost)"""
    b = Bench()
    b.alive("learner", "old")
    b.alive("learner", "new")
    assert b.arb.active_learner() == "old"
    for _ in range(3):
        b.arb.on_select(KEYS.select_learner, encode(SelectLearner("new")), b.now)
    assert b.arb.active_learner() == "new" and b.arb.counts["swaps"] == 1
