"""Gathering one tick's proposals up to a deadline (Algorithm 2, steps 2-4), without a bus.

A tick is ready when its input and a proposal from every expected member are in, or when its
deadline passes. Proposals may arrive before their input (they travel other routes).
"""
from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

from bus_schema import Proposal


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

    def _entry(self, tick: int, now: float) -> PendingTick | None:
        if tick in self._decided:
            return None
        entry = self._pending.get(tick)
        if entry is None:
            entry = self._pending[tick] = PendingTick(tick, now + self.deadline_s)
        return entry

    def add_input(self, tick: int, stamp: float, x: np.ndarray, now: float) -> None:
        if tick in self._decided:  # the platform restarted its tick count: forget the old run
            self._decided.clear()
        entry = self._entry(tick, now)
        entry.x, entry.stamp = x, stamp

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
