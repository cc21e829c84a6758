"""Ball-seeking pieces: the colour-blind slot layout, its teacher, the protocol's helpers."""
import numpy as np
import pytest

from bus_schema.spaces import Spaces
from services.experiments.ballseek import ball_in_view, ball_spot
from services.platforms.aibo.arena_layout import EYE_HEIGHT, arena_layout, in_sight
from services.experiments.ballseek_protocol import schedule_end
from services.perception.blobs import BlobDetector
from services.perception.slots import BlobSlots
from services.platforms.aibo.platform import MOVE_BOX
from services.teachers.ballseek import BallSeekTeacher, SlotBallSeekTeacher

PINK, ORANGE = [1.0, 0.3, 0.1, 0.01], [1.0, -0.5, 0.2, 0.04]
NONE = [0.0] * 4
ARENA_WITH_HIDING_PLACES = 5


def test_slots_put_the_largest_blob_first_and_round_trip():
    slots = BlobSlots()
    both = np.array(PINK + ORANGE)
    encoded = slots.encode(both)
    assert slots.names()[:5] == ("blob1_seen", "blob1_x", "blob1_y", "blob1_area", "blob1_orange")
    np.testing.assert_array_equal(encoded, ORANGE + [1.0] + PINK + [0.0])  # orange is bigger
    np.testing.assert_array_equal(slots.decode(encoded), both)
    assert slots.box().contains(encoded)


def test_pink_alone_and_orange_alone_share_the_first_slot_but_the_colour():
    slots = BlobSlots()
    pink, orange = slots.encode(np.array(PINK + NONE)), slots.encode(np.array(NONE + PINK))
    np.testing.assert_array_equal(pink[:4], orange[:4])
    assert (pink[4], orange[4]) == (0.0, 1.0)


def test_slot_teacher_seeks_pink_and_ignores_orange_like_the_colour_teacher():
    slots = BlobSlots()
    colour_teacher = BallSeekTeacher(Spaces(BlobDetector().box(), MOVE_BOX))
    slot_teacher = SlotBallSeekTeacher(Spaces(slots.box(), MOVE_BOX), slots)
    for blobs in (PINK + NONE, NONE + ORANGE, PINK + ORANGE, NONE + NONE):
        blobs = np.array(blobs)
        np.testing.assert_array_equal(slot_teacher(slots.encode(blobs))[0], colour_teacher(blobs)[0])


def test_ball_in_view_reads_either_layout():
    slots, rows = BlobSlots(), [PINK + NONE, NONE + ORANGE, PINK + ORANGE, NONE + NONE]
    pink, orange = [True, False, True, False], [False, True, True, False]
    encoded = np.array([slots.encode(np.array(r)) for r in rows])
    for layout, xs in (("colours", np.array(rows)), ("slots", encoded)):
        assert ball_in_view(xs, layout, "pink").tolist() == pink
        assert ball_in_view(xs, layout, "orange").tolist() == orange


def test_ball_spots_lie_in_the_ring_around_the_robot_pose():
    rng = np.random.default_rng(0)
    spots = np.array([ball_spot(rng, 0.5, 1.0, bearing=(-0.4, 0.4), pose=((1.0, 1.0), np.pi / 2)) for _ in range(200)])
    offsets = spots - 1.0
    distance, bearing = np.hypot(*offsets.T), np.arctan2(offsets[:, 1], offsets[:, 0]) - np.pi / 2
    assert distance.min() >= 0.5 and distance.max() <= 1.0 and np.abs(bearing).max() <= 0.4 + 1e-9


def test_a_ball_put_down_for_an_episode_is_in_sight_of_the_robot():
    """Arena 5's clutter hides some of the ring around the robot; spots drawn with the arena are
    all in sight, and without it some are not (so the check is doing something)."""
    layout = arena_layout(ARENA_WITH_HIDING_PLACES)
    free, placed = np.random.default_rng(1), np.random.default_rng(1)
    unchecked = [ball_spot(free) for _ in range(300)]
    checked = [ball_spot(placed, arena=ARENA_WITH_HIDING_PLACES) for _ in range(300)]
    assert not all(in_sight(layout, spot) for spot in unchecked)
    assert all(in_sight(layout, spot) for spot in checked)


def test_in_sight_agrees_with_the_physics_ray_test():
    """The arena alone (no robot in the way of the rays), built by PyBullet from the same seed."""
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    from services.platforms.aibo.arena import Arena

    layout, rng = arena_layout(ARENA_WITH_HIDING_PLACES), np.random.default_rng(3)
    spots = [ball_spot(rng) for _ in range(80)]
    client = BulletClient(pybullet.DIRECT)
    try:
        arena = Arena(client, ARENA_WITH_HIDING_PLACES)
        agree = 0
        for x, y in spots:
            arena.place_ball("pink", (x, y))
            clear = any(client.rayTest([0, 0, EYE_HEIGHT], [x, y, z])[0][0] in (-1, arena.balls["pink"]) for z in (0.04,
                                                                                                                   0.08))
            agree += clear == in_sight(layout, (x, y))
    finally:
        client.disconnect()
    assert agree >= len(spots) - 2  # lines that graze a box's edge may go either way


@pytest.mark.parametrize("teach, end", [(60, 80.0), (30, 30.0), (45, 55.0), (100, 80.0)])
def test_schedule_end_is_when_the_schedule_has_given_the_teaching(teach, end):
    assert schedule_end(((0, 30), (40, 60), (70, 80)), teach) == end


def test_a_ball_is_never_put_down_against_clutter_where_physics_would_roll_it_away():
    """Seed 0's seventh correction put (arena 803659) drew a spot 2 cm from a box: the ball rolled
    17 cm in a second, and the live protocol could not tell the reset had landed. ball_spot draws again."""
    from services.experiments.ballseek import BallWorld
    from services.platforms.aibo.arena_layout import touches_clutter
    against = (0.765, 0.185)
    assert touches_clutter(arena_layout(803659), against)
    world = BallWorld(0)
    try:
        world.start(803659, {"orange": against})
        for _ in range(20):
            world.platform.step(np.zeros(2), 0.05)
        assert np.hypot(*(world.sim.ball_positions()["orange"][:2] - against)) > 0.05  # why it matters
    finally:
        world.close()
    rng = np.random.default_rng(4)
    for arena in rng.integers(1_000_000, size=150):
        spot = ball_spot(rng, arena=int(arena))
        assert not touches_clutter(arena_layout(int(arena)), spot), (arena, spot)
