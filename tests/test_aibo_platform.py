"""AiboPlatform specifics beyond the shared conformance checks."""
from __future__ import annotations

import numpy as np
import pytest

from services.platforms import make_platform
from services.platforms.aibo import JOINT_LIMITS, JOINT_NAMES
from services.platforms.aibo.platform import AiboPlatform


def test_joint_mode_spaces_are_the_18_named_joints_in_radians():
    with make_platform("aibo", camera=True) as platform:
        for box in (platform.spaces.input, platform.spaces.output):
            assert box.names == JOINT_NAMES and set(box.units) == {"rad"}
            assert np.array_equal(box.low, JOINT_LIMITS[:, 0]) and np.array_equal(box.high, JOINT_LIMITS[:, 1])
        assert platform.spaces.extra["camera"] == {"width": 208, "height": 160, "vertical_fov_deg": 45.2,
                                                   "encoding": "jpeg"}


def test_move_mode_takes_forward_and_turn():
    with AiboPlatform(command="move", camera=False) as platform:
        assert platform.spaces.output.names == ("forward", "turn")
        assert platform.spaces.output.units == ("m/s", "rad/s")
        assert platform.spaces.input.names == JOINT_NAMES
        assert np.array_equal(platform.step(np.array([9.0, -9.0]), 0.05), [0.15, -0.8])


def test_wrong_command_shape_says_what_to_send():
    with AiboPlatform(camera=False) as platform:
        with pytest.raises(ValueError,
                           match=r"expected 18 command values for the aibo in 'joints' mode, got shape \(17,\)"):
            platform.step(np.zeros(17), 0.05)
    with pytest.raises(ValueError, match="command must be one of"):
        AiboPlatform(command="fly")


def test_applied_command_shows_handled_joints_following_the_handler():
    with AiboPlatform(camera=False) as platform:
        mask = np.zeros(18, dtype=bool)
        mask[16:] = True
        handled = platform.observe()
        handled[16:] = JOINT_LIMITS[16:, 1]
        platform.sim.set_handled(mask, handled)
        applied = platform.step(platform.observe(), 0.05)
        assert np.array_equal(applied[16:], JOINT_LIMITS[16:, 1])
