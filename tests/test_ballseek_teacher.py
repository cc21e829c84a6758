"""BallSeekTeacher: seek, centre, approach the pink ball, ignore orange; signs checked on the physics."""
import numpy as np
import pytest

from bus_schema.spaces import Box, Spaces
from services.perception.blobs import BlobDetector
from services.platforms.aibo.platform import MOVE_BOX
from services.teachers import make_teacher
from services.teachers.ballseek import BallSeekTeacher

SPACES = Spaces(BlobDetector().box(), MOVE_BOX)


def blobs(pink=None, orange=None):
    """Blob vector in the detector's layout; each ball given as (x, y, area) or None for unseen."""
    vector = []
    for ball in (pink, orange):
        vector += [0.0, 0.0, 0.0, 0.0] if ball is None else [1.0, *ball]
    return np.array(vector)


def test_registered_and_confident():
    teacher = make_teacher("ballseek", SPACES)
    y, confidence = teacher(blobs())
    assert isinstance(teacher, BallSeekTeacher) and confidence == 1.0 and y.shape == (2,)


def test_the_registered_name_reads_the_slot_layout_too():
    from services.perception.slots import BlobSlots
    from services.teachers.ballseek import SlotBallSeekTeacher

    slots = BlobSlots()
    teacher = make_teacher("ballseek", Spaces(slots.box(), MOVE_BOX))
    pink_right = blobs(pink=(0.5, 0.0, 0.01))
    assert isinstance(teacher, SlotBallSeekTeacher)
    np.testing.assert_array_equal(teacher(slots.encode(pink_right))[0], BallSeekTeacher(SPACES)(pink_right)[0])


def test_searches_left_on_the_spot_when_no_pink_ball_is_seen():
    y, _ = BallSeekTeacher(SPACES)(blobs())
    assert y[0] == 0.0 and y[1] > 0  # turn is left-positive


def test_turns_toward_the_ball_and_walks_when_centred():
    teacher = BallSeekTeacher(SPACES)
    right, _ = teacher(blobs(pink=(0.6, 0.0, 0.01)))
    left, _ = teacher(blobs(pink=(-0.6, 0.0, 0.01)))
    ahead, _ = teacher(blobs(pink=(0.0, 0.3, 0.02)))
    assert right[1] < 0 < left[1]
    assert ahead[1] == 0.0 and ahead[0] == pytest.approx(MOVE_BOX.high[0])
    assert right[0] < ahead[0]


def test_a_ball_entering_at_the_left_edge_continues_the_search():
    teacher = BallSeekTeacher(SPACES)
    np.testing.assert_allclose(teacher(blobs(pink=(-1.0, 0.0, 0.001)))[0], teacher(blobs())[0])


def test_ignores_the_orange_ball():
    teacher = BallSeekTeacher(SPACES)
    np.testing.assert_array_equal(teacher(blobs(orange=(0.0, 0.2, 0.02)))[0], teacher(blobs())[0])
    np.testing.assert_array_equal(teacher(blobs(pink=(0.4, 0.1, 0.01), orange=(-0.3, 0.2, 0.05)))[0],
                                  teacher(blobs(pink=(0.4, 0.1, 0.01)))[0])


def test_outputs_stay_within_the_move_limits():
    teacher = BallSeekTeacher(SPACES, forward_speed=1.0, turn_gain=5.0)
    for x in np.linspace(-1, 1, 21):
        assert MOVE_BOX.contains(teacher(blobs(pink=(x, 0.0, 0.01)))[0])


def test_refuses_inputs_without_the_colour_it_seeks():
    spaces = Spaces(Box((0.0,) * 4, (1.0,) * 4, ("orange_seen", "orange_x", "orange_y", "orange_area")), MOVE_BOX)
    with pytest.raises(ValueError, match=r"needs inputs \['pink_seen', 'pink_x'\]"):
        BallSeekTeacher(spaces)


def test_approaches_a_ball_placed_ahead_and_to_the_right_on_the_physics():
    from services.experiments.ballseek import BallWorld
    from services.experiments.judges import nose_to_ball

    world = BallWorld(seed=0, inputs="colours")
    try:
        world.start(0, {"pink": (0.75, -0.3)})  # right of the robot, which faces +x: image x > 0
        first = world.observe()
        assert first[0] == 1.0 and first[1] > 0
        teacher, start = BallSeekTeacher(world.spaces), nose_to_ball(world.sim, "pink")
        for _ in range(50):  # 10 s at 5 Hz
            world.platform.step(teacher(world.observe())[0], 0.2)
            if nose_to_ball(world.sim, "pink") < 0.2:
                break
        assert start > 0.6 and nose_to_ball(world.sim, "pink") < 0.2
    finally:
        world.close()
