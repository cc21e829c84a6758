"""The soak's person at the ball-seeking page with a gamepad stick (rigs/live/page.StickPerson), on a fake page:
the stick held where the teacher's answer is, as the page reads a pad (axis 1 down, axis 0 right), to a stick's
steps; the live page reading such a pad is tests/test_ui_page.py's gamepad test."""
import numpy as np

from bus_schema.spaces import Spaces
from rigs.live.page import PAD_PLUGGED, StickPerson
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
        # the page: forward = -axis 1, turn left = -axis 0
        np.testing.assert_allclose([-axes[1], -axes[0]], fractions, atol=0.5 / StickPerson.STEPS + 1e-12)
        assert all(abs(a * StickPerson.STEPS - round(a * StickPerson.STEPS)) < 1e-9 for a in axes)
        answers.append(axes)
    assert len({tuple(a) for a in answers}) > 2, "the answers differ by degrees, not only by side"


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
