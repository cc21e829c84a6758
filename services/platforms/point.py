"""A point moving in a box of any dimensionality: the built-in platform for tests and benchmarks.

The input is a stimulus wandering smoothly over [-1, 1]^n (seeded), followed by the point's own
position; the command is the point's target position, which it approaches at a bounded speed.
A teacher defines the task as a function of the stimulus; nothing here knows the task.
"""
from __future__ import annotations

import numpy as np

from bus_schema.spaces import Box, Spaces


class PointPlatform:
    def __init__(self, dims: int = 2, seed: int = 0, speed: float = 2.0, wander_hz: float = 0.3):
        if dims < 1:
            raise ValueError(f"dims must be >= 1, got {dims}")
        self.dims, self.seed, self.speed, self.wander_hz = dims, seed, speed, wander_hz
        stimulus = Box.uniform(dims, -1.0, 1.0, "stimulus", "1")
        position = Box.uniform(dims, -1.0, 1.0, "position", "m")
        self.spaces = Spaces(
            input=Box(stimulus.low + position.low, stimulus.high + position.high,
                      stimulus.names + position.names, stimulus.units + position.units),
            output=Box.uniform(dims, -1.0, 1.0, "target", "m"),
            extra={"platform": "point", "dims": dims},
        )
        self._closed = False
        self.reset(seed)

    def reset(self, seed: int | None = None) -> np.ndarray:
        rng = np.random.default_rng(self.seed if seed is None else seed)
        # a sum of incommensurate sines per dimension: smooth, bounded, covers the box, repeatable
        self._freqs = self.wander_hz * rng.uniform(0.5, 1.5, size=(self.dims, 3))
        self._phases = rng.uniform(0, 2 * np.pi, size=(self.dims, 3))
        self._time = 0.0
        self._position = np.zeros(self.dims)
        return self.observe()

    def _stimulus(self) -> np.ndarray:
        waves = np.sin(2 * np.pi * self._freqs * self._time + self._phases).sum(axis=1)
        return np.clip(waves / 2.2, -1.0, 1.0)

    def observe(self) -> np.ndarray:
        return np.concatenate([self._stimulus(), self._position])

    def step(self, command: np.ndarray, dt: float) -> np.ndarray:
        applied = self.spaces.output.clip(np.asarray(command, dtype=np.float64))
        delta = applied - self._position
        distance = float(np.linalg.norm(delta))
        reach = self.speed * dt
        self._position = applied.copy() if distance <= reach else self._position + delta * (reach / distance)
        self._time += dt
        return applied

    def hold(self, dt: float) -> None:
        self._time += dt  # the world goes on; the point stays where it is

    def close(self) -> None:
        self._closed = True

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
