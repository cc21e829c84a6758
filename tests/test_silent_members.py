"""A ghost `alive/teaching/<x>` token once made every tick wait for the 20 ms deadline (issue 12). A
member that misses MISSES_BEFORE_IGNORED deadlines in a row is no longer waited for, until it answers."""
import numpy as np
import zenoh

from bus_schema import Input, Proposal, encode
from services.arbitration.strategies import TeacherFirst
from services.boxes.arbitrator import MISSES_BEFORE_IGNORED, Arbitrator
from tests.fakebus import fake_box
from tests.test_boxes_clip import KEYS, SPACES

DEADLINE = 0.02


def tick(arb, t, n, answer_from=("learner/student",)):
    """Input n at time t, proposals from `answer_from` 1 ms later; returns when tick n was decided."""
    arb.on_input(KEYS.input, encode(Input(n, t, np.zeros(2))), t)
    for member in answer_from:
        role, name = member.split("/")
        arb.on_proposal(f"{KEYS.prefix}/proposal/{role}/{name}", encode(Proposal(n, member, np.zeros(2), 0.9)),
                        t + 0.001)
    for wait in (0.001, DEADLINE):
        before = arb.counts["commands"]
        arb.decide_ready(t + wait)
        if arb.counts["commands"] > before:
            return wait
    raise AssertionError(f"tick {n} not decided")


def test_a_ghost_teacher_is_waited_for_a_few_ticks_then_not_until_it_answers():
    arb = Arbitrator(fake_box("arbitrator"), SPACES, TeacherFirst(), DEADLINE, "student", "teacher", 16)
    for member in (KEYS.alive("learner", "student"), KEYS.alive("teaching", "ghost")):
        arb.on_alive(member, zenoh.SampleKind.PUT)
    waits = [tick(arb, float(n), n) for n in range(1, 21)]
    assert waits[:MISSES_BEFORE_IGNORED] == [DEADLINE] * MISSES_BEFORE_IGNORED
    assert max(waits[MISSES_BEFORE_IGNORED:]) < DEADLINE  # decided as soon as the learner answered
    assert arb.report()[1]["not_waited_for"] == ["teacher/ghost"] and arb.counts["members_silenced"] == 1
    # it answers (a frozen teacher thawed): waited for again, and its teaching is taken
    assert tick(arb, 30.0, 30, ("learner/student", "teacher/ghost")) < DEADLINE
    assert arb.report()[1]["not_waited_for"] == [] and arb.counts["train_pairs"] == 1
    assert tick(arb, 31.0, 31) == DEADLINE  # silent again: waited for, a deadline at a time


def test_a_teacher_that_holds_no_teaching_token_does_not_drive_or_teach():
    """(publishing on proposal/teacher/<any name> drove the robot and trained the learner: issue 12)"""
    arb = Arbitrator(fake_box("arbitrator"), SPACES, TeacherFirst(), DEADLINE, "student", "teacher", 16)
    arb.on_alive(KEYS.alive("learner", "student"), zenoh.SampleKind.PUT)
    tick(arb, 1.0, 1, ("learner/student", "teacher/stranger"))
    assert arb.counts["train_pairs"] == 0 and arb.counts["mode_teacher"] == 0
    assert arb.counts["teacher_proposals_without_token"] == 1
    arb.on_alive(KEYS.alive("teaching", "alice"), zenoh.SampleKind.PUT)
    tick(arb, 2.0, 2, ("learner/student", "teacher/alice"))
    assert arb.counts["train_pairs"] == 1 and arb.counts["mode_teacher"] == 1
