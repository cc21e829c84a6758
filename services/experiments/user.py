"""The person in the loop, scripted: switches the teacher on and off on a schedule and, if asked,
answers the robot's unsure requests (green ears) with probability p by teaching for a while.

This is the paper's mixed initiative (section IV: "whether or not the education is provided
depends on the human user"), repeatable by seed. A real person does the same with `dogged teach`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def parse_schedule(text: str) -> tuple[tuple[float, float], ...]:
    """'0-20,30-35' -> ((0, 20), (30, 35)): seconds of simulated time when the teacher is on."""
    spans = []
    for part in filter(None, (p.strip() for p in text.split(","))):
        start, _, stop = part.partition("-")
        try:
            spans.append((float(start), float(stop)))
        except ValueError:
            raise ValueError(f"schedule entry {part!r} is not 'start-stop' in seconds, e.g. '0-20,30-35'") from None
    return normalise(spans)


def normalise(spans) -> tuple[tuple[float, float], ...]:
    spans = tuple((float(a), float(b)) for a, b in spans)
    for a, b in spans:
        if not 0 <= a < b:
            raise ValueError(f"schedule span ({a}, {b}) must have 0 <= start < stop")
    return tuple(sorted(spans))


@dataclass
class ScriptedUser:
    """`teaching(t, unsure)` is called once per tick, in time order: True when the teacher should be
    on. Scheduled spans always teach; outside them, each new unsure request (the first unsure tick
    after a confident one) is answered with probability `answer_probability` by `answer_seconds` of
    teaching. The random draws come from `seed` alone, so the same run gets the same answers."""

    schedule: tuple[tuple[float, float], ...] = ()
    answer_probability: float = 0.0
    answer_seconds: float = 2.0
    seed: int = 0

    def __post_init__(self):
        self.schedule = normalise(self.schedule)
        if not 0.0 <= self.answer_probability <= 1.0:
            raise ValueError(f"answer_probability must be in [0, 1], got {self.answer_probability}")
        self._rng = np.random.default_rng([self.seed, 23])
        self._answer_until = -np.inf
        self._was_unsure = False

    def scheduled(self, t: float) -> bool:
        return any(a <= t < b for a, b in self.schedule)

    def teaching(self, t: float, unsure: bool = False) -> bool:
        new_request = unsure and not self._was_unsure
        self._was_unsure = unsure
        if self.scheduled(t) or t < self._answer_until:
            return True
        if new_request and self.answer_probability > 0 and self._rng.random() < self.answer_probability:
            self._answer_until = t + self.answer_seconds
            return True
        return False

    @property
    def scheduled_seconds(self) -> float:
        return sum(b - a for a, b in self.schedule)
