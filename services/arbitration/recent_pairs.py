"""The arbitrator's recent training pairs, from which a learner fills a gap: a ring of fixed arrays.

Held as one TrainingPair object each (arrays, a dataclass, strings), 65,536 mirroring pairs took about
40 MB, growing for the first half hour of an all-day run (benchmarks/soak.py); here the ring is its full
size and written once at the start, so the process's memory does not grow with it at all.
"""
from __future__ import annotations

import numpy as np

from bus_schema.teachers import TeacherColumn


class RecentPairs:
    """The last `capacity` pairs of an epoch, numbered by seq without gaps (1, 2, ...)."""

    def __init__(self, capacity: int, n_in: int, n_out: int):
        if capacity < 1:
            raise ValueError(f"recent pairs: capacity must be at least 1, got {capacity}")
        self.capacity = capacity
        # filled, not only allocated: the pages are the process's from the start (np.zeros maps them lazily)
        self._x = np.full((capacity, n_in), np.nan)
        self._y = np.full((capacity, n_out), np.nan)
        self._mask = np.ones((capacity, n_out), dtype=bool)
        self._teacher = np.zeros(capacity, dtype=np.uint8)  # who taught each (numbered by self.teachers)
        self.teachers = TeacherColumn()
        self.last_seq = 0  # the newest pair's seq; 0: none yet

    def __len__(self) -> int:
        return min(self.last_seq, self.capacity)

    @property
    def first_seq(self) -> int:
        """The oldest pair still held (last_seq + 1 when none is)."""
        return self.last_seq - len(self) + 1

    def append(self, seq: int, x: np.ndarray, y: np.ndarray, mask: np.ndarray | None, source: str = "") -> None:
        if seq != self.last_seq + 1:
            raise ValueError(f"recent pairs: seq {seq} does not follow {self.last_seq}")
        row = (seq - 1) % self.capacity
        self._x[row], self._y[row] = x, y
        self._mask[row] = True if mask is None else mask != 0
        self._teacher[row] = self.teachers.number(source or "unnamed")
        self.last_seq = seq

    def rows(self, first: int, last: int) -> tuple:
        """The pairs with first <= seq <= last still held, as PairBatch's fields after the epoch: first seq, xs, ys,
        masks as 0/1, and who taught each (teachers, teacher_of); none when the range holds none of them (then
        first seq is `first`)."""
        lo, hi = max(first, self.first_seq), min(last, self.last_seq)
        if lo > hi:
            n_in, n_out = self._x.shape[1], self._y.shape[1]
            return first, np.empty((0, n_in)), np.empty((0, n_out)), np.empty((0, n_out)), "", b""
        idx = (np.arange(lo, hi + 1) - 1) % self.capacity
        return (lo, self._x[idx], self._y[idx], self._mask[idx].astype(np.float64),
                *self.teachers.encoded(self._teacher[idx]))
