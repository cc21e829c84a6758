"""The platform contract (Gymnasium's habit): a tiny interface, spaces declared as data.

A platform is plain Python with no bus in it; `services.boxes.platform` puts one on Zenoh, and
services/platforms/checks.py (the conformance suite) holds every registered platform to this.
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from bus_schema.spaces import Spaces


@runtime_checkable
class Platform(Protocol):
    """Optional attribute hold_settle_seconds: the seconds hold() may take to bring the robot to rest (a
    walking robot puts its feet down), at most checks.MAX_HOLD_SETTLE_SECONDS; 0 if absent."""

    spaces: Spaces

    def reset(self, seed: int | None = None) -> np.ndarray:
        """Start an episode; returns the first input (shape spaces.input.dims)."""

    def observe(self) -> np.ndarray:
        """The current input, float64, shape (spaces.input.dims,)."""

    def step(self, command: np.ndarray, dt: float) -> np.ndarray:
        """Apply `command` clipped to spaces.output, advance `dt` seconds; returns the command applied."""

    def hold(self, dt: float) -> None:
        """Watchdog action: no fresh command, come to rest (within hold_settle_seconds) and hold
        still, for `dt` seconds."""

    def close(self) -> None:
        """Release resources; idempotent."""
