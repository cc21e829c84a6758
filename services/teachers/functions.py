"""Hand-coded teachers that are functions of the input (the paper's 'compiled' demonstrators)."""
from __future__ import annotations

import numpy as np

from bus_schema.spaces import Spaces


class SineTeacher:
    """y_i = amplitude * sin(frequency * x_{(i+1) mod k}) over the first k inputs: a smooth
    nonlinear task for the point platform whose stimulus fills the first inputs."""

    def __init__(self, spaces: Spaces, amplitude: float = 0.8, frequency: float = 2.0, inputs: int | None = None):
        self.spaces, self.amplitude, self.frequency = spaces, amplitude, frequency
        self.inputs = inputs or min(spaces.input.dims, spaces.output.dims)
        if not 1 <= self.inputs <= spaces.input.dims:
            raise ValueError(f"inputs must be in 1..{spaces.input.dims}, got {self.inputs}")

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray | None, float]:
        n_out = self.spaces.output.dims
        source = x[(np.arange(n_out) + 1) % self.inputs]
        return self.spaces.output.clip(self.amplitude * np.sin(self.frequency * source)), 1.0


class CopyTeacher:
    """Copies chosen inputs to chosen outputs ([[input, output], ...], or [input, output, gain, offset]
    for y = gain * x + offset); every other output is `rest`, or, with partial=True, left to the
    student (the teacher speaks only for its outputs: `mask`)."""

    def __init__(self, spaces: Spaces, pairs: list = ((0, 0),), rest: float = 0.0, partial: bool = False):
        self.spaces, self.rest = spaces, rest
        self.pairs = [(int(p[0]), int(p[1])) for p in pairs]
        self.maps = [(float(p[2]), float(p[3])) if len(p) == 4 else (1.0, 0.0) for p in pairs]
        for i, o in self.pairs:
            if not (0 <= i < spaces.input.dims and 0 <= o < spaces.output.dims):
                raise ValueError(f"pair ({i}, {o}) is outside {spaces.input.dims} inputs / "
                                 f"{spaces.output.dims} outputs")
        self.mask = None
        if partial:
            self.mask = np.zeros(spaces.output.dims)
            self.mask[[o for _, o in self.pairs]] = 1.0

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray | None, float]:
        y = np.full(self.spaces.output.dims, self.rest, dtype=np.float64)
        for (i, o), (gain, offset) in zip(self.pairs, self.maps):
            y[o] = gain * x[i] + offset
        return self.spaces.output.clip(y), 1.0


def _mirror_axes() -> dict:
    """(tail joint, head joint, gain, offset) per axis. Pan is a plain copy (the tail's +-45 deg fit
    the head's range); the tail tilts over 5..60 deg but the head over -75..0 deg, so a plain copy
    would always clip to 0: tilt maps the tail's range onto the head's (tail raised -> head up)."""
    from services.platforms.aibo.joints import HEAD_PAN, HEAD_TILT, JOINT_LIMITS, TAIL_PAN, TAIL_TILT
    (tail_low, tail_high), (head_low, head_high) = JOINT_LIMITS[TAIL_TILT], JOINT_LIMITS[HEAD_TILT]
    gain = (head_low - head_high) / (tail_high - tail_low)
    return {"tilt": (TAIL_TILT, HEAD_TILT, float(gain), float(head_high - gain * tail_low)),
            "pan": (TAIL_PAN, HEAD_PAN, 1.0, 0.0)}


class MirrorTeacher(CopyTeacher):
    """The paper's mirroring teacher: the head follows the tail (axes 'both', 'pan' or 'tilt')."""

    def __init__(self, spaces: Spaces, axes: str = "both"):
        if axes not in ("both", "pan", "tilt"):
            raise ValueError(f"axes must be 'both', 'pan' or 'tilt', got {axes!r}")
        table = _mirror_axes()
        chosen = table.values() if axes == "both" else [table[axes]]
        # a one-axis teacher leaves the other outputs to the student, so two teachers can merge
        super().__init__(spaces, pairs=list(chosen), partial=axes != "both")


class HoldTeacher:
    """A default controller: always answers `value` (e.g. stand still) with a fixed confidence."""

    def __init__(self, spaces: Spaces, value: float = 0.0, confidence: float = 0.5):
        self.y = spaces.output.clip(np.full(spaces.output.dims, value, dtype=np.float64))
        self.confidence = confidence

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray | None, float]:
        return self.y.copy(), self.confidence
