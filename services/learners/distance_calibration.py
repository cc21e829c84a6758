"""How far from its nearest sample an answer stays right, learned from the stream being taught.

A memory-based learner's confidence falls with the distance to what it remembers; the question is in
what units. A width fixed by the input's dimension is right only for maps that happen to vary on that
scale: on random 4 -> 2 maps taught along smooth trajectories, kNN with the fixed width was sure of
91 % of its answers at 0.19 RMS (span 2), and asked on 5 % of the ticks it was wrong on.

Each new pair is first answered by the memory without its newest RECENT samples: on a smooth stream
those lie along the same pass, so what is left is what a query off the pass would be answered from,
as the robot's own inputs are once the teacher is gone. Its error, as a share of the taught span,
over the distance to the nearest sample used, is how fast answers go wrong with distance here (the
slope). The width makes confidence 0.25, where the robot asks, at the distance at which the median
slope reaches ASK_AT of the span. A memory that never errs keeps the given width.
"""
from __future__ import annotations

import math

import numpy as np

RECENT = 60  # newest samples left out when a new pair is judged (2 s of a 30 Hz stream)
KEEP = 2000  # the newest slopes the width comes from
MIN_JUDGED = 20  # before this many, the given width
ASK_AT = 0.1  # share of the taught span an answer may be off where the robot asks
Z_ASK = math.sqrt(2.0 * math.log(4.0))  # exp(-z^2 / 2) = 0.25


class DistanceCalibration:
    """The newest KEEP slopes (error share per unit of distance) and the width they give."""

    def __init__(self):
        self.slopes = np.zeros(KEEP)
        self.count = 0
        self._width: float | None = None  # cached until the next judged pair

    def judge(self, error_share: float, distance: float) -> None:
        if not (distance > 0.0 and math.isfinite(distance) and math.isfinite(error_share)):
            return
        self.slopes[self.count % KEEP] = error_share / distance
        self.count += 1
        self._width = None

    def width(self, given: float) -> float:
        if self.count < MIN_JUDGED:
            return given
        if self._width is None:
            slope = float(np.median(self.slopes[:min(self.count, KEEP)]))
            self._width = ASK_AT / (Z_ASK * slope) if slope > 0.0 else given
        return self._width

    def __getstate__(self) -> dict:
        return {"slopes": self.slopes[:min(self.count, KEEP)].copy(), "count": self.count}

    def __setstate__(self, state: dict) -> None:
        """From a snapshot, which may come from the bus: slopes are finite and >= 0, the count matches."""
        kept = np.asarray(state["slopes"], dtype=np.float64).ravel()[:KEEP]
        self.slopes = np.zeros(KEEP)
        self.slopes[:len(kept)] = np.clip(np.nan_to_num(kept, nan=0.0, posinf=0.0), 0.0, None)
        count = int(state["count"])
        self.count = count if len(kept) == KEEP and count >= KEEP else len(kept)
        self._width = None
