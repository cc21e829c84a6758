"""A handler asking for a variety of outputs: a new random point of the output space every `every`
seconds (each output held at the space's middle with probability `still`), whatever the input.

Run with --role default on an upper level, it asks a lower level for movements while the upper
level's own student is untaught (a default controller trains nobody): the walk level of
deploy/hierarchy.toml learns its gait before anyone teaches ball seeking.
"""
from __future__ import annotations

import time

import numpy as np

from bus_schema.spaces import Spaces


class WanderTeacher:
    def __init__(self, spaces: Spaces, every: float = 1.5, still: float = 0.3, seed: int = 0, clock=time.monotonic):
        if not (isinstance(every, (int, float)) and np.isfinite(every) and every > 0):
            raise ValueError(f"every must be a positive number of seconds, got {every!r}")
        if not (isinstance(still, (int, float)) and 0.0 <= still <= 1.0):
            raise ValueError(f"still must be a probability from 0 to 1, got {still!r}")
        self.spaces, self.every, self.still, self.clock = spaces, float(every), float(still), clock
        self.rng = np.random.default_rng(seed)
        self.low, self.high = np.asarray(spaces.output.low), np.asarray(spaces.output.high)
        self.middle = (self.low + self.high) / 2.0
        self.until, self.y = -np.inf, self.middle

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray | None, float]:
        now = self.clock()
        if now >= self.until:
            self.until = now + self.every
            y = self.rng.uniform(self.low, self.high)
            held = self.rng.random(len(y)) < self.still
            self.y = np.where(held, self.middle, y)
        return self.y.copy(), 1.0
