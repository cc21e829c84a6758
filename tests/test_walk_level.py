"""The walk level on the physics (issue 16, acceptance 1): a minute of the hand-coded trot teaching
the default learner while a handler asks for movements, then the learned gait alone walks forward
at least 0.5 m in 10 s and turns at least 45 degrees each way in 10 s, without falling."""
import numpy as np
import pytest

from bus_schema import Spaces
from services.experiments.walk import learned_gait, taught_walk_model, walk_alone, walk_spaces
from services.platforms.aibo.gait import TrotGait
from services.platforms.aibo.platform import LEGS_BOX, MOVE_BOX, PHASE_BOX
from services.teachers.trot import TrotTeacher

TEACHING_S = 60.0


@pytest.fixture(scope="module")
def learned():
    return learned_gait(taught_walk_model(TEACHING_S, seed=0))


@pytest.mark.slow
def test_the_learned_gait_walks_forward_half_a_metre_in_ten_seconds(learned):
    walked = walk_alone(learned, 0.15, 0.0)
    print(f"after {TEACHING_S:.0f} s of teaching: {walked.distance_m:.2f} m forward in 10 s")
    assert walked.distance_m >= 0.5
    assert walked.lowest_upright > 0.9


@pytest.mark.slow
@pytest.mark.parametrize("direction", [1, -1], ids=["left", "right"])
def test_the_learned_gait_turns_45_degrees_each_way_in_ten_seconds(learned, direction):
    walked = walk_alone(learned, 0.0, direction * 0.8)
    print(f"turned {np.degrees(walked.turned_rad):+.0f} degrees in 10 s")
    assert direction * walked.turned_rad >= np.radians(45)
    assert walked.lowest_upright > 0.9


def test_the_trot_teacher_is_the_gait_as_a_function_of_command_and_phase():
    spaces = walk_spaces()
    assert spaces.input.names == ("forward", "turn", "phase_sin", "phase_cos") and spaces.output == LEGS_BOX
    teacher, gait = TrotTeacher(spaces), TrotGait()
    for phase in (0.0, 0.3, 0.75):
        y, confidence = teacher(np.array([0.1, -0.4, np.sin(2 * np.pi * phase), np.cos(2 * np.pi * phase)]))
        assert confidence == 1.0 and np.allclose(y, gait.pose_at(0.1, -0.4, phase))
    standing, _ = teacher(np.array([0.0, 0.0, 0.0, 1.0]))
    assert np.allclose(standing, gait.stand_pose()), "asked for no movement, the trot stands"
    default = TrotTeacher(spaces, stand=True)  # the walk level's default controller
    assert np.allclose(default(np.array([0.15, 0.8, 1.0, 0.0]))[0], gait.stand_pose())


def test_the_trot_teacher_names_what_its_spaces_lack():
    with pytest.raises(ValueError, match="missing phase_sin, phase_cos"):
        TrotTeacher(Spaces(MOVE_BOX, LEGS_BOX))
    walk_input = walk_spaces().input
    with pytest.raises(ValueError, match="answers 12 leg joint targets, but the output space has 2"):
        TrotTeacher(Spaces(walk_input, PHASE_BOX))


def test_a_robot_that_walks_movements_with_the_walk_level_teaches_it_on_the_way():
    """services.experiments.hierarchy: each 15 Hz movement becomes four 60 Hz walk ticks; teaching,
    the trot drives and the learner learns every pair; untaught and alone, the default stands."""
    from services.experiments.hierarchy import LegsUnderMovement
    from services.learners import make_learner
    model = make_learner("knn", 4, 12)
    legs = LegsUnderMovement(0, model, teaching=False)
    try:
        for _ in range(15):
            legs.step(np.array([0.15, 0.0]), 1 / 15)
        assert legs.modes == {"unsure": 60} and legs.sim.base_pose()[0][0] < 0.01, "untaught: it stands"
        legs.teaching = True
        start = legs.sim.base_pose()[0]
        for _ in range(75):
            legs.step(np.array([0.15, 0.0]), 1 / 15)
        assert legs.taught_ticks == 300 and model.n_learned == 300
        assert np.hypot(*(legs.sim.base_pose()[0] - start)[:2]) > 0.2
    finally:
        legs.close()
