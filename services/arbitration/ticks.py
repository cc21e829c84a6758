"""Gathering one tick's proposals up to a deadline (Algorithm 2, steps 2-4), without a bus.

A tick is ready when its input and a proposal from every expected member are in, or when its
deadline passes. Proposals may arrive before their input (they travel other routes).
"""
from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

from bus_schema import Proposal

# an input may run this many ticks past the last one (an hour at 30 Hz of inputs lost); further is not
# trusted until CONFIRMING more inputs have followed on from it (a link that was down that long)
MAX_TICK_JUMP, CONFIRMING = 100_000, 3


@dataclass
class PendingTick:
    tick: int
    deadline: float
    x: np.ndarray | None = None
    stamp: float = 0.0
    proposals: dict[str, Proposal] = field(default_factory=dict)


class TickTable:
    def __init__(self, deadline_s: float, remember: int = 4096):
        self.deadline_s = deadline_s
        self._pending: dict[int, PendingTick] = {}
        self._decided: OrderedDict[int, None] = OrderedDict()
        self._remember = remember
        self.late = 0
        self._last_input: int | None = None
        self._jumped: list[int] = []  # inputs far past the last, each following on from the one before

    def _entry(self, tick: int, now: float) -> PendingTick | None:
        if tick in self._decided:
            return None
        entry = self._pending.get(tick)
        if entry is None:
            entry = self._pending[tick] = PendingTick(tick, now + self.deadline_s)
        return entry

    def add_input(self, tick: int, stamp: float, x: np.ndarray, now: float) -> None:
        """Raises ValueError, the input unused, for a tick implausibly far past the last input's."""
        self._check_jump(tick)
        if tick in self._decided:  # the platform restarted its tick count: forget the old run
            self._decided.clear()
        entry = self._entry(tick, now)
        entry.x, entry.stamp = x, stamp

    def _check_jump(self, tick: int) -> None:
        last = self._last_input
        if last is None or tick <= last + MAX_TICK_JUMP:  # on, or back (the platform restarted)
            self._last_input, self._jumped = tick, []
            return
        if self._jumped and self._jumped[-1] < tick <= self._jumped[-1] + MAX_TICK_JUMP:
            self._jumped.append(tick)
        else:
            self._jumped = [tick]
        if len(self._jumped) > CONFIRMING:  # a stream that goes on from there: the platform's own
            self._last_input, self._jumped = tick, []
            return
        raise ValueError(f"input tick {tick} jumps {tick - last} past the last input's ({last}); "
                         f"taken once {CONFIRMING} more follow on from it")

    def add_proposal(self, member: str, proposal: Proposal, now: float) -> None:
        entry = self._entry(proposal.tick, now)
        if entry is None:
            self.late += 1
        else:
            entry.proposals[member] = proposal

    def ready(self, expected: set[str], now: float) -> list[PendingTick]:
        """Ticks to decide now, oldest first: complete ones, and those past their deadline with an input."""
        out = []
        for tick, entry in list(self._pending.items()):
            complete = entry.x is not None and expected.issubset(entry.proposals)
            if complete or now >= entry.deadline:
                del self._pending[tick]
                if entry.x is None:  # proposals for an input that never came: nothing to answer
                    continue
                self._decided[tick] = None
                if len(self._decided) > self._remember:
                    self._decided.popitem(last=False)
                out.append(entry)
        out.sort(key=lambda e: e.tick)
        return out

    def next_deadline(self) -> float | None:
        return min((e.deadline for e in self._pending.values()), default=None)

    def __len__(self) -> int:
        return len(self._pending)
