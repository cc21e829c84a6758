"""`dogged arena` says done only when the robot's own states show the reset (issue 30: without --ball it
said done whenever any state came, so a reset the robot refused, or the bus did, passed silently)."""
import numpy as np

from bus_schema import RobotState
from services.supervisor.commands import reset_confirmed


def state(sim_time: float, pink=(0.7, 0.2)) -> RobotState:
    return RobotState(sim_time, np.zeros(3), np.zeros(3), {"pink": [*pink, 0.04]}, "", np.zeros(4))


def test_states_that_go_on_without_a_reset_confirm_nothing():
    flowing = [state(t) for t in (3.0, 3.1, 3.2, 3.3)]
    assert not reset_confirmed(flowing, 1, {})  # what was taken for done before
    assert not reset_confirmed(flowing, 1, {"pink": [0.7, 0.2]})


def test_the_simulated_time_starting_again_after_the_request_is_the_reset():
    assert reset_confirmed([state(3.0), state(3.1), state(0.1), state(0.2)], 2, {})
    assert reset_confirmed([state(3.0), state(0.05)], 1, {})


def test_a_reset_before_the_request_or_balls_elsewhere_do_not_count():
    assert not reset_confirmed([state(3.0), state(0.1), state(0.2)], 2, {})  # someone else's, earlier
    assert not reset_confirmed([state(3.0), state(0.1, pink=(0.0, 0.0))], 1, {"pink": [0.7, 0.2]})
    assert reset_confirmed([state(3.0), state(0.1, pink=(0.0, 0.0)), state(0.2)], 1, {"pink": [0.7, 0.2]})


def test_states_that_do_not_decode_are_skipped():
    assert reset_confirmed([state(3.0), None, state(0.1)], 1, {})
