import numpy as np
import pytest

from bus_schema import Proposal
from services.arbitration.strategies import STRATEGIES, HighestConfidence, PredictiveLearning, TeacherFirst
from services.arbitration.ticks import TickTable


def P(y, c, tick=1, source="x/y"):
    return Proposal(tick, source, None if y is None else np.asarray(y, float), c)


HOLD = np.zeros(2)


def test_teacher_first_teacher_wins_and_trains():
    d = TeacherFirst().decide([("teacher/t", P([1, 1], 0.1))], ("learner/l", P([2, 2], 0.9)), None, HOLD)
    assert (d.mode, d.source, d.train) == ("teacher", "teacher/t", True)
    np.testing.assert_array_equal(d.y, [1, 1])


def test_student_and_unsure_by_threshold():
    s = TeacherFirst(unsure_below=0.25)
    assert s.decide([], ("learner/l", P([2, 2], 0.3)), None, HOLD).mode == "student"
    d = s.decide([], ("learner/l", P([2, 2], 0.2)), None, HOLD)
    assert (d.mode, d.train) == ("unsure", False)


def test_default_controller_takes_over_when_unsure():
    d = TeacherFirst().decide([], ("learner/l", P([2, 2], 0.1)), ("default/stand", P([0, 0], 0.5)), HOLD)
    assert (d.mode, d.source) == ("unsure", "default/stand")


def test_no_learner_holds_the_last_command():
    d = TeacherFirst().decide([], None, None, np.array([3.0, 4.0]))
    assert d.source == "hold" and list(d.y) == [3.0, 4.0]


def test_confidence_strategy_lets_a_confident_student_drive():
    d = HighestConfidence().decide([("teacher/new", P([1, 1], 0.4))], ("learner/l", P([2, 2], 0.9)), None, HOLD)
    assert (d.mode, d.train) == ("student", False)
    d = HighestConfidence().decide([("teacher/t", P([1, 1], 1.0))], ("learner/l", P([2, 2], 0.9)), None, HOLD)
    assert d.mode == "teacher"


def test_two_teachers_highest_confidence_then_name():
    d = TeacherFirst().decide([("teacher/b", P([1, 1], 1.0)), ("teacher/a", P([2, 2], 1.0))], None, None, HOLD)
    assert d.source == "teacher/a"


def test_predictive_learning_stops_training_once_error_is_low():
    s = PredictiveLearning(error_threshold=0.01, window=3)
    for _ in range(3):
        d = s.decide([("teacher/t", P([1, 1], 1.0))], ("learner/l", P([1.01, 1], 0.9)), None, HOLD)
        assert d.train
    assert s.acting
    d = s.decide([("teacher/t", P([1, 1], 1.0))], ("learner/l", P([5, 5], 0.9)), None, HOLD)
    assert (d.mode, d.train, list(d.y)) == ("student", False, [5, 5])


@pytest.mark.parametrize("name", sorted(STRATEGIES))
def test_every_strategy_answers_every_case(name):
    """Conformance for the strategy plug-in point: always a finite output of the right size."""
    s = STRATEGIES[name]()
    cases = [([], None, None), ([("teacher/t", P([1, 1], 1.0))], None, None),
             ([], ("learner/l", P([2, 2], 0.0)), None), ([], ("learner/l", P([2, 2], 1.0)), ("default/d", P([0, 0],
                                                                                                            1)))]
    for teachers, learner, default in cases:
        d = s.decide(teachers, learner, default, HOLD)
        assert d.y.shape == (2,) and np.all(np.isfinite(d.y)) and d.mode in ("teacher", "student", "unsure")
        assert 0.0 <= d.confidence <= 1.0


def test_tick_waits_for_every_expected_member_then_deadline():
    table = TickTable(deadline_s=0.02)
    table.add_input(1, 0.0, np.zeros(2), now=0.0)
    table.add_proposal("learner/l", P([1, 1], 0.5, tick=1), now=0.0)
    assert table.ready({"learner/l", "teacher/t"}, now=0.001) == []
    ready = table.ready({"learner/l", "teacher/t"}, now=0.021)
    assert [e.tick for e in ready] == [1] and set(ready[0].proposals) == {"learner/l"}


def test_proposal_before_input_and_late_proposals():
    table = TickTable(deadline_s=1.0)
    table.add_proposal("learner/l", P([1, 1], 0.5, tick=5), now=0.0)
    assert table.ready({"learner/l"}, now=0.0) == []  # no input yet
    table.add_input(5, 0.0, np.zeros(2), now=0.0)
    assert [e.tick for e in table.ready({"learner/l"}, now=0.0)] == [5]
    table.add_proposal("learner/l", P([1, 1], 0.5, tick=5), now=0.1)
    assert table.late == 1 and len(table) == 0


def test_platform_restart_resets_tick_memory():
    table = TickTable(deadline_s=1.0)
    table.add_input(1, 0.0, np.zeros(2), now=0.0)
    assert len(table.ready(set(), now=0.0)) == 1
    table.add_input(1, 0.0, np.zeros(2), now=1.0)  # tick numbers start again
    assert len(table.ready(set(), now=1.0)) == 1


def test_partial_teachers_merge_with_the_student():
    pan = Proposal(1, "teacher/pan", np.array([0.0, 5.0, 0.0]), 1.0, np.array([0.0, 1.0, 0.0]))
    tilt = Proposal(1, "teacher/tilt", np.array([7.0, 0.0, 0.0]), 1.0, np.array([1.0, 0.0, 0.0]))
    student = ("learner/l", P([1, 2, 3], 0.9))
    d = TeacherFirst().decide([("teacher/pan", pan)], student, None, np.zeros(3))
    assert list(d.y) == [1, 5, 3] and d.train
    assert list(d.mask) == [0, 1, 0], "only the taught output is to be learned"
    d = TeacherFirst().decide([("teacher/pan", pan), ("teacher/tilt", tilt)], student, None, np.zeros(3))
    assert list(d.y) == [7, 5, 3] and list(d.mask) == [1, 1, 0]
    whole = TeacherFirst().decide([("teacher/t", P([1, 1, 1], 1.0))], student, None, np.zeros(3))
    assert whole.mask is None


def test_a_teachers_choice_trains_as_one_hot_where_the_outputs_are_a_choice():
    from services.arbitration.algorithm2 import decide
    from bus_schema.spaces import Box
    box = Box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    teacher = [("teacher/person", P([0.2, 0.7, 0.4], 1.0))]
    d, _ = decide(TeacherFirst(), teacher, None, None, np.zeros(3), box, choice=True)
    assert d.train and d.y.tolist() == [0.0, 1.0, 0.0]
    d, _ = decide(TeacherFirst(), teacher, None, None, np.zeros(3), box)  # not a choice: as given
    assert d.y.tolist() == [0.2, 0.7, 0.4]
    d, _ = decide(TeacherFirst(), [], ("learner/l", P([0.2, 0.7, 0.4], 0.9)), None, np.zeros(3), box, choice=True)
    assert d.y.tolist() == [0.2, 0.7, 0.4]  # the student's answer is sent as it is: the platform takes the largest
