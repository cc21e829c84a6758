"""Which run of its platform each recorded sample belongs to.

A restarted platform counts its ticks from 1 again (the arbitrator takes a tick it has decided before
as such a restart), and no field of the bus says which run an input is of; so a tick alone names no
input of a recording that spans a restart. Here the recording itself says: a run begins where an
input's tick is not past the tick of the last input received. Another sample of a tick (a proposal,
the command, a training pair) belongs to the run whose input of that tick was received nearest to it,
within MATCH_S; failing that, to the run of the last input received before it.
"""
from __future__ import annotations

import numpy as np

# a tick's proposals, command and pair come within this of its input (deadlines are tens of ms), while a
# platform takes longer to restart and reach the same tick again
MATCH_S = 1.0


class PlatformRuns:
    """Feed it the samples in the order they were received: `add_input` for each input, `run_of` after
    every input has been added."""

    def __init__(self):
        self.current = -1  # the run of the last input received (-1: none yet)
        self._last_tick: int | None = None
        self._received: dict[int, list[tuple[int, int]]] = {}  # tick -> (log_ns, run) of its inputs

    def add_input(self, tick: int, log_ns: int) -> int:
        """The run this input is of (0, 1, ...)."""
        if self._last_tick is None or tick <= self._last_tick:
            self.current += 1
        self._last_tick = tick
        self._received.setdefault(tick, []).append((log_ns, self.current))
        return self.current

    def run_of(self, tick: int, log_ns: int, received_in: int) -> int:
        """The run of a sample of `tick` received at `log_ns`, while run `received_in` was current."""
        nearest = min(self._received.get(tick, ()), key=lambda seen: abs(seen[0] - log_ns), default=None)
        if nearest is not None and abs(nearest[0] - log_ns) <= MATCH_S * 1e9:
            return nearest[1]
        return max(received_in, 0)


def runs_of_inputs(ticks, log_ns) -> np.ndarray:
    """The run of each input of a sequence in the order received."""
    runs = PlatformRuns()
    return np.array([runs.add_input(int(tick), int(ns)) for tick, ns in zip(ticks, log_ns)], dtype=np.int64)
