"""A mirroring teacher whose tilt axis is not constant.

`services.teachers.functions.MirrorTeacher` copies tail readings to head targets. For pan that
is fine (tail +-45 deg fits in the head's +-88 deg), but the tail tilts over 5..60 deg and the
head over -75..0 deg, so the copied tilt is always clipped to 0: the tilt "task" is a constant
and teaching it proves nothing. This teacher maps each tail axis linearly onto the head axis's
range instead (pan: a plain copy, as MirrorTeacher; tilt: tail raised (5 deg) -> head up (0),
tail lowered (60 deg) -> head down (-75 deg)). Proposed for functions.py; until then it lives here.
"""
from __future__ import annotations

import numpy as np

from services.platforms.aibo.joints import HEAD_PAN, HEAD_TILT, JOINT_LIMITS, TAIL_PAN, TAIL_TILT
from services.teachers.functions import MirrorTeacher


def _tilt_map() -> tuple[float, float]:
    """(gain, offset) taking the tail tilt's range onto the head tilt's, raised tail to head up."""
    (tail_low, tail_high), (head_low, head_high) = JOINT_LIMITS[TAIL_TILT], JOINT_LIMITS[HEAD_TILT]
    gain = (head_low - head_high) / (tail_high - tail_low)
    return float(gain), float(head_high - gain * tail_low)


# (input, output) -> (gain, offset)
_MAPS = {(TAIL_PAN, HEAD_PAN): (1.0, 0.0), (TAIL_TILT, HEAD_TILT): _tilt_map()}


class RangeMirrorTeacher(MirrorTeacher):
    """MirrorTeacher(axes) with each copied axis mapped onto the head's range; partial the same way."""

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray | None, float]:
        y = np.full(self.spaces.output.dims, self.rest, dtype=np.float64)
        for i, o in self.pairs:
            gain, offset = _MAPS[(i, o)]
            y[o] = gain * x[i] + offset
        return self.spaces.output.clip(y), 1.0
