"""Mirroring in one process: the student learns to mirror the tail, ignoring the distractors."""
import numpy as np
import pytest

from bus_schema.spaces import Spaces
from services.experiments import mirroring
from services.experiments.loop import tick
from services.learners import make_learner
from services.platforms.aibo.joints import HEAD_PAN, HEAD_TILT, JOINT_LIMITS, TAIL_PAN, TAIL_TILT
from services.platforms.aibo.platform import JOINTS_BOX
from services.teachers.functions import MirrorTeacher

SPACES = Spaces(JOINTS_BOX, JOINTS_BOX)


def test_mirror_teacher_spans_the_head_tilt_range_and_copies_pan():
    teacher = MirrorTeacher(SPACES)
    x = np.zeros(18)
    x[TAIL_TILT], x[TAIL_PAN] = JOINT_LIMITS[TAIL_TILT, 0], 0.3
    raised, _ = teacher(x)
    x[TAIL_TILT] = JOINT_LIMITS[TAIL_TILT, 1]
    lowered, _ = teacher(x)
    assert raised[HEAD_TILT] == JOINT_LIMITS[HEAD_TILT, 1] and lowered[HEAD_TILT] == JOINT_LIMITS[HEAD_TILT, 0]
    assert raised[HEAD_PAN] == 0.3
    assert MirrorTeacher(SPACES, axes="tilt").mask[HEAD_TILT] == 1 and MirrorTeacher(SPACES,
                                                                                     axes="tilt").mask.sum() == 1


def test_a_partial_teacher_sets_its_axis_and_the_student_the_rest():
    learner = make_learner("knn", 18, 18)
    learner.learn_one(np.zeros(18), np.full(18, 0.1))
    x = np.zeros(18)
    x[TAIL_PAN] = 0.4
    decision, student_y, _ = tick(x, [("teacher/pan", MirrorTeacher(SPACES, axes="pan"))], learner)
    assert decision.mode == "teacher" and decision.train
    assert decision.y[HEAD_PAN] == 0.4 and decision.y[HEAD_TILT] == student_y[HEAD_TILT]


@pytest.mark.slow
def test_student_mirrors_a_held_out_tail_after_a_few_seconds_of_teaching():
    untaught = make_learner("lwpr", 18, 18, seed=3)
    before = mirroring.held_out_error(untaught, seed=3, seconds=3.0)
    result = mirroring.one_teacher(3, max_teach=6.0, check_every=3.0, held_out_seconds=3.0, alone_seconds=1.0)
    assert before > 0.2
    assert result.final_error < mirroring.ERROR_BOUND
    arrays = result.trace.arrays()
    assert arrays["teaching"][:180].all() and not arrays["teaching"][-30:].any()  # 6 s taught, 1 s alone at 30 Hz


def test_head_readings_that_echo_the_command_do_not_hold_the_student_back():
    """Seed 6 is the slowest mirroring seed: while taught, the head readings follow the commanded
    head and the distractors drift along with the tail, nearly collinear with what matters. The
    wired learner must mirror the whole held-out sweep after 3 s all the same."""
    result = mirroring.one_teacher(6, max_teach=3.0, check_every=1.5, held_out_seconds=5.0, alone_seconds=0.5)
    assert result.final_error < mirroring.ERROR_BOUND


def test_lwpr_local_fits_are_not_biased_by_head_readings_that_echo_the_command():
    """The same seed with LWPR, whose answers are held to the taught range (+10 %): judged on the
    held-out ticks whose head targets lie in the range taught, where holding does not act, its exact
    local fits must be right (ridge prior 1e-4: 0.030 rad over those 90 ticks; 1e-8: 0.0001 rad)."""
    run = mirroring.new_run(6, "lwpr")
    teacher = MirrorTeacher(run.platform.spaces, axes="both")
    run.run(3.0, {"teacher/mirror": teacher})
    taught = run.trace.arrays()["y"][:, list(mirroring.HEAD_AXES)]
    held = mirroring.MirrorRun(6, run.learner, run.platform, mirroring.Handler(
        seed=6 + mirroring.HELD_OUT_SEED_OFFSET, distractors=mirroring.MIRRORING_DISTRACTORS))
    run.platform.reset(6 + mirroring.HELD_OUT_SEED_OFFSET)
    held.run(5.0, teachers={})
    arrays = held.trace.arrays()
    reference = np.array([teacher(x)[0] for x in arrays["x"]])[:, list(mirroring.HEAD_AXES)]
    inside = np.all((reference >= taught.min(0)) & (reference <= taught.max(0)), axis=1)
    run.platform.close()
    errors = arrays["student"][inside][:, list(mirroring.HEAD_AXES)] - reference[inside]
    assert inside.sum() > 30 and np.sqrt(np.mean(errors ** 2)) < 0.005, (inside.sum(), np.sqrt(np.mean(errors ** 2)))


def test_per_output_student_trains_only_the_outputs_the_teacher_speaks_for():
    student = make_learner("per-output", 18, 18, base="knn")
    x = np.zeros(18)
    x[TAIL_PAN] = 0.4
    decision, _, _ = tick(x, [("teacher/pan", MirrorTeacher(SPACES, axes="pan"))], student)
    after = student.predict_one(x).y
    assert decision.train and after[HEAD_PAN] == pytest.approx(0.4)
    assert student._parts[HEAD_TILT].n_learned == 0 and student._parts[HEAD_PAN].n_learned == 1


def test_two_partial_teachers_in_turn_merge_when_only_taught_outputs_train():
    result = mirroring.two_teachers(4, seconds_each=5.0, held_out_seconds=3.0, alone_seconds=0.5, masked=True)
    after_pan, merged = result.curve[0][1], result.curve[1][1]
    assert after_pan > 0.2  # pan alone leaves tilt untaught
    assert merged < mirroring.ERROR_BOUND
