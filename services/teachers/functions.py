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
    """Copies chosen inputs to chosen outputs ([[input, output], ...]); every other output is `rest`,
    or, with partial=True, left to the student (the teacher speaks only for its outputs: `mask`)."""

    def __init__(self, spaces: Spaces, pairs: list = ((0, 0),), rest: float = 0.0, partial: bool = False):
        self.spaces, self.rest = spaces, rest
        self.pairs = [(int(i), int(o)) for i, o in pairs]
        for i, o in self.pairs:
            if not (0 <= i < spaces.input.dims and 0 <= o < spaces.output.dims):
                raise ValueError(f"pair ({i}, {o}) is outside {spaces.input.dims} inputs / {spaces.output.dims} outputs")
        self.mask = None
        if partial:
            self.mask = np.zeros(spaces.output.dims)
            self.mask[[o for _, o in self.pairs]] = 1.0

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray | None, float]:
        y = np.full(self.spaces.output.dims, self.rest, dtype=np.float64)
        for i, o in self.pairs:
            y[o] = x[i]
        return self.spaces.output.clip(y), 1.0


# Aibo joint order (services.platforms.aibo): 12 head_tilt, 13 head_pan, 16 tail_tilt, 17 tail_pan
_MIRROR_AXES = {"tilt": (16, 12), "pan": (17, 13)}


class MirrorTeacher(CopyTeacher):
    """The paper's mirroring teacher: the head follows the tail (axes 'both', 'pan' or 'tilt')."""

    def __init__(self, spaces: Spaces, axes: str = "both"):
        if axes not in ("both", "pan", "tilt"):
            raise ValueError(f"axes must be 'both', 'pan' or 'tilt', got {axes!r}")
        chosen = _MIRROR_AXES.values() if axes == "both" else [_MIRROR_AXES[axes]]
        # a one-axis teacher leaves the other outputs to the student, so two teachers can merge
        super().__init__(spaces, pairs=list(chosen), partial=axes != "both")


class HoldTeacher:
    """A default controller: always answers `value` (e.g. stand still) with a fixed confidence."""

    def __init__(self, spaces: Spaces, value: float = 0.0, confidence: float = 0.5):
        self.y = spaces.output.clip(np.full(spaces.output.dims, value, dtype=np.float64))
        self.confidence = confidence

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray | None, float]:
        return self.y.copy(), self.confidence
