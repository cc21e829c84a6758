"""A teacher of a map nobody designed: a random smooth function of chosen inputs onto chosen
outputs, drawn from a seed like the tasks of benchmarks/unknown.py. It stands for the task a new
user brings: `dogged run demonstrator --teacher random-map --param seed=3 --param inputs=[16,17]
--param outputs=[12,13]` teaches the Aibo's head a curved function of its tail."""
from __future__ import annotations

import numpy as np

from bus_schema.spaces import Box, Spaces
from services.learners.unknown_tasks import draw_target


def _indices(box: Box, chosen, field: str) -> list[int]:
    """Indices of `chosen` (indices or the box's names) in `box`, or ValueError naming the field."""
    if isinstance(chosen, (int, str)):
        chosen = [chosen]
    out = []
    for item in chosen:
        if isinstance(item, str) and item in box.names:
            out.append(box.names.index(item))
        elif isinstance(item, int) and not isinstance(item, bool) and 0 <= item < box.dims:
            out.append(item)
        else:
            known = f"indices 0..{box.dims - 1}" + (f" or names {', '.join(box.names)}" if box.names else "")
            raise ValueError(f"{field}: {item!r} is not one of the space's {known}")
    if not out or len(set(out)) != len(out):
        raise ValueError(f"{field}: expected distinct entries, got {chosen!r}")
    return out


class RandomMapTeacher:
    """From `seed`, y[outputs] = a smooth random map of x[inputs] (each input scaled to [-1, 1] over
    its bounds), spanning `span` (output units; default 90 % of each output's range) around the
    middle of each output's range. A partial teacher: `mask` marks the outputs it speaks for."""

    def __init__(self, spaces: Spaces, seed: int = 0, inputs=(0, 1), outputs=(0,), span: float | None = None):
        if not isinstance(seed, int) or isinstance(seed, bool):
            raise ValueError(f"seed: expected an integer, got {seed!r}")
        self.spaces = spaces
        self.inputs = _indices(spaces.input, inputs, "inputs")
        self.outputs = _indices(spaces.output, outputs, "outputs")
        low, high = (np.asarray(b, dtype=np.float64) for b in (spaces.output.low, spaces.output.high))
        if span is not None and not (isinstance(span, (int, float)) and 0 < span):
            raise ValueError(f"span: expected a positive number, got {span!r}")
        reach = 0.9 * (high - low) if span is None else np.minimum(float(span), high - low)
        self._half, self._middle = reach[self.outputs] / 2, ((low + high) / 2)
        rng = np.random.default_rng([seed, 17])
        self._maps = [draw_target(rng, len(self.inputs)) for _ in self.outputs]
        self._in_low = np.asarray(spaces.input.low, dtype=np.float64)[self.inputs]
        self._in_high = np.asarray(spaces.input.high, dtype=np.float64)[self.inputs]
        self.mask = np.zeros(spaces.output.dims)
        self.mask[self.outputs] = 1.0

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray | None, float]:
        u = 2.0 * (np.asarray(x, dtype=np.float64)[self.inputs] - self._in_low) / (self._in_high - self._in_low) - 1.0
        y = self._middle.copy()
        y[self.outputs] += self._half * np.array([g(u[None, :])[0] for g in self._maps])
        return self.spaces.output.clip(y), 1.0
