"""The soak's person at the ball-seeking page with a gamepad stick (rigs/live/page.StickPerson), on a fake page:
the stick held where the page says the teacher's answer, as the page reads a pad (axis 1 down, axis 0 right, a
dead zone), to a stick's steps; the live page reading such a pad is tests/test_ui_page.py's gamepad test."""
import re

import numpy as np

from bus_schema.spaces import Spaces
from rigs.harness import REPO
from rigs.live.page import PAD_DEAD_ZONE, PAD_PLUGGED, StickPerson, pad_says
from services.perception.slots import BlobSlots
from services.platforms.aibo.platform import MOVE_BOX
from services.teachers import make_teacher

SLOTS = BlobSlots()
SPACES = Spaces(SLOTS.box(), MOVE_BOX)


class FakePage:
    def __init__(self):
        self.calls = []

    def evaluate(self, script, arg=None):
        self.calls.append((script, arg))


def seen(pink_x: float | None, area: float = 0.01) -> np.ndarray:
    """The perception slots' vector with the pink ball at pink_x (None: nothing seen)."""
    blobs = [0.0, 0.0, 0.0, 0.0] if pink_x is None else [1.0, pink_x, 0.0, area]
    return SLOTS.encode(np.array(blobs + [0.0, 0.0, 0.0, 0.0]))


def test_the_stick_is_where_the_teachers_answer_is_to_a_sticks_steps():
    page = FakePage()
    person = StickPerson(page, SPACES)
    assert page.calls == [(PAD_PLUGGED, None)]
    teacher = make_teacher("ballseek", SPACES)
    low, high = np.array(MOVE_BOX.low), np.array(MOVE_BOX.high)
    answers = []
    for pink_x in (None, -0.6, -0.1, 0.0, 0.3, 0.8):
        x = seen(pink_x)
        y, _ = teacher(x)
        axes = person.axes_for(x)
        fractions = (np.asarray(y) - (low + high) / 2) / ((high - low) / 2)
        # the page: forward = -axis 1, turn left = -axis 0; a step of the stick past the dead zone says 1/108
        said = [pad_says(-axes[1]), pad_says(-axes[0])]
        np.testing.assert_allclose(said, fractions, atol=0.5 / (StickPerson.STEPS * (1 - PAD_DEAD_ZONE)) + 1e-12)
        assert all(abs(a * StickPerson.STEPS - round(a * StickPerson.STEPS)) < 1e-9 for a in axes)
        answers.append(axes)
    assert len({tuple(a) for a in answers}) > 2, "the answers differ by degrees, not only by side"


def test_a_gentle_turn_is_said_past_the_dead_zone_not_as_none():
    """The ball almost centred asks a turn of a few hundredths: the stick goes just past the dead zone, and the
    page says a few hundredths, where a stick's own value there said no turn at all."""
    person = StickPerson(FakePage(), SPACES)
    teacher = make_teacher("ballseek", SPACES)
    x = seen(0.05)
    turn = teacher(x)[0][1] / MOVE_BOX.high[1]
    assert 0 < abs(turn) < PAD_DEAD_ZONE
    axis = person.axes_for(x)[0]
    assert abs(axis) > PAD_DEAD_ZONE
    assert abs(pad_says(-axis) - turn) <= 0.5 / (StickPerson.STEPS * (1 - PAD_DEAD_ZONE))


def test_the_says_are_the_pages():
    """The page's dead zone and its scaling past it, as app.js says them (the person inverts the page's)."""
    app = (REPO / "services" / "ui" / "static" / "app.js").read_text()
    assert re.search(rf"const PAD_DEAD_ZONE = {PAD_DEAD_ZONE};", app)
    assert "(Math.abs(v) - PAD_DEAD_ZONE) / (1 - PAD_DEAD_ZONE)" in app
    assert pad_says(PAD_DEAD_ZONE) == 0.0 and pad_says(-1.0) == -1.0 and pad_says(1.0) == 1.0
    assert 0 < pad_says(PAD_DEAD_ZONE + 0.01) < 0.02


def test_driving_holds_the_stick_and_letting_go_centres_it():
    page = FakePage()
    person = StickPerson(page, SPACES)
    x = seen(0.5)
    person.drive(x, 0.0)
    assert page.calls[-1][1] == person.axes_for(x) and person.held
    person.drive(None, 0.1)  # nothing seen yet: the stick stays where it was
    assert page.calls[-1][1] == person.axes_for(x)
    person.release()
    assert page.calls[-1][1] == [0.0, 0.0] and not person.held
