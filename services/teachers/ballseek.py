"""The paper's ball-seeking demonstrator (section V.B): seek, centre and approach the pink ball.

Input: the colour-blob vector of `services.perception.blobs.BlobDetector` (per colour: seen,
x, y, area; x -1 left ... +1 right). Output: (forward m/s, turn rad/s, left positive), the
"move" command the Aibo's trot walks. A pure function of the input, as the paper's compiled
teachers were, so a student can learn it from (input, output) pairs alone.

Sign convention, checked on the physics (tests/test_ballseek_teacher.py): a ball at image
x > 0 lies to the robot's right, and a negative turn turns right, so turn = -gain * x.
"""
from __future__ import annotations

import numpy as np

from bus_schema.spaces import Spaces
from services.perception.slots import BlobSlots

# the detector's default layout, used when the input space carries no names
DEFAULT_NAMES = ("pink_seen", "pink_x", "pink_y", "pink_area", "orange_seen", "orange_x", "orange_y", "orange_area")


class BallSeekTeacher:
    """Not seen: turn left on the spot (search). Seen: turn toward it (turn = -turn_gain * x) and walk
    forward the more the ball is centred (full speed within `centred` of the middle, none at the
    edge). At the image's left edge both rules give the same command, so the policy is continuous
    where a ball enters view while searching, which keeps it learnable. Other colours are ignored."""

    def __init__(self, spaces: Spaces, colour: str = "pink", forward_speed: float = 0.15, turn_gain: float = 0.8,
                 search_turn: float = 0.8, centred: float = 0.3):
        names = tuple(spaces.input.names) or DEFAULT_NAMES[: spaces.input.dims]
        wanted = (f"{colour}_seen", f"{colour}_x")
        missing = [name for name in wanted if name not in names]
        if missing:
            raise ValueError(f"BallSeekTeacher needs inputs {missing}; got {names}. Feed it the blob vector of "
                             f"services.perception.blobs.BlobDetector (see BlobDetector().describe())")
        if spaces.output.dims != 2:
            raise ValueError(f"BallSeekTeacher outputs (forward, turn), but the output space has {spaces.output.dims} "
                             "dims; use AiboPlatform(command='move')")
        self.spaces, self.colour = spaces, colour
        self.forward_speed, self.turn_gain = forward_speed, turn_gain
        self.search_turn, self.centred = search_turn, centred
        self._seen, self._x = names.index(wanted[0]), names.index(wanted[1])

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray | None, float]:
        if x[self._seen] < 0.5:
            command = np.array([0.0, self.search_turn])
        else:
            offset = float(x[self._x])
            # linear from full speed when centred to zero at the edge, so walking never takes the ball out of view
            walk = np.clip((1.0 - abs(offset)) / (1.0 - self.centred), 0.0, 1.0)
            command = np.array([self.forward_speed * walk, -self.turn_gain * offset])
        return self.spaces.output.clip(command), 1.0


class SlotBallSeekTeacher:
    """BallSeekTeacher reading the colour-blind slot layout (decoded back to per-colour blobs)."""

    def __init__(self, spaces: Spaces, slots: BlobSlots | None = None, **params):
        self.slots = slots or BlobSlots()
        self.spaces = spaces
        self._teacher = BallSeekTeacher(Spaces(self.slots.detector.box(), spaces.output), **params)

    def __call__(self, x: np.ndarray):
        return self._teacher(self.slots.decode(x))


def ball_seek_teacher(spaces: Spaces, **params):
    """The ball-seeking teacher for whichever blob layout the input space names: the detector's
    per-colour layout (BallSeekTeacher) or the colour-blind slots (SlotBallSeekTeacher)."""
    slots = BlobSlots()
    if tuple(spaces.input.names) == slots.names():
        return SlotBallSeekTeacher(spaces, slots, **params)
    return BallSeekTeacher(spaces, **params)
