"""What a chain of instances is apart from the bus (services/boxes/chain.py puts it on Zenoh; the in-process
experiments of two levels use it as the box does): the lower instance's spaces, and the easing of each
new upper command.
"""
from __future__ import annotations

import numpy as np

from bus_schema import Box, Spaces


class Easing:
    """First-order easing towards the latest target over `seconds` (0: none, the target as it is)."""

    def __init__(self, start: np.ndarray, seconds: float):
        self.value, self.seconds = np.array(start, dtype=np.float64), seconds

    def step(self, target: np.ndarray, dt: float) -> np.ndarray:
        blend = 1.0 - np.exp(-max(dt, 0.0) / self.seconds) if self.seconds > 0 else 1.0
        self.value = self.value + blend * (np.asarray(target, dtype=np.float64) - self.value)
        return self.value


def lower_spaces(upper: Spaces, consumer: Spaces, extra: Spaces | None) -> Spaces:
    """The lower instance's spaces: input the upper's output (then the extra stream's inputs, if any), output
    the consumer's."""
    box = upper.output
    if extra is not None:
        box = Box(box.low + extra.input.low, box.high + extra.input.high, box.names + extra.input.names,
                  box.units + extra.input.units)
    return Spaces(box, consumer.output, {"chained_from": "upper instance's output"})
