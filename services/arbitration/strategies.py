"""Arbitration strategies (Algorithm 2, step 5): pick one output from the proposals of a tick.

Pure Python: no bus. A strategy sees the teachers' proposals (non-null ones only), the active
learner's proposal and the default controller's, and returns a Decision.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bus_schema import Proposal


@dataclass(frozen=True)
class Decision:
    y: np.ndarray
    mode: str          # teacher | student | unsure (the robot's request for teaching)
    source: str        # "teacher/<name>", "learner/<id>", "default/<name>" or "hold"
    confidence: float
    train: bool        # whether (x, y) goes to the learners
    mask: np.ndarray | None = None  # outputs the teachers taught (None: all); only those are to be learned


def _best(proposals: list[tuple[str, Proposal]]) -> tuple[str, Proposal]:
    # highest confidence; ties go to the first name in sorted order, so the choice is repeatable
    return max(sorted(proposals, key=lambda item: item[0]), key=lambda item: item[1].confidence)


def _teach(teachers, learner, fallback) -> tuple[str, Proposal, np.ndarray, np.ndarray | None]:
    """The teachers' output and the outputs they taught. Partial teachers (with a mask) set only
    their outputs; the others keep the student's (or the held) output for the robot, but are not
    taught: a student trained on its own guess for an untaught axis would unlearn it, and two
    teachers of different axes could never merge (docs/results.md)."""
    name, best = _best(teachers)
    if best.mask is None:
        return name, best, best.y, None
    y = np.array(learner[1].y if learner is not None else fallback, dtype=np.float64)
    taught = np.zeros(len(y), dtype=bool)
    # lower confidence first, so the most confident teacher has the last word on a shared output
    for _, p in sorted(teachers, key=lambda item: (item[1].confidence, item[0])):
        chosen = p.mask.astype(bool) if p.mask is not None else np.ones(len(y), dtype=bool)
        y[chosen] = p.y[chosen]
        taught |= chosen
    return name, best, y, None if taught.all() else taught.astype(np.float64)


class TeacherFirst:
    """The paper's strategy: a non-null teacher output wins (the teacher is assumed right)."""

    def __init__(self, unsure_below: float = 0.25):
        self.unsure_below = unsure_below

    def decide(self, teachers, learner, default, fallback: np.ndarray) -> Decision:
        if teachers:
            name, p, y, taught = _teach(teachers, learner, fallback)
            return Decision(y, "teacher", name, p.confidence, True, taught)
        return self._student(learner, default, fallback)

    def _student(self, learner, default, fallback) -> Decision:
        if learner is None:
            if default is not None:
                return Decision(default[1].y, "unsure", default[0], default[1].confidence, False)
            return Decision(fallback, "unsure", "hold", 0.0, False)
        name, p = learner
        if p.confidence >= self.unsure_below:
            return Decision(p.y, "student", name, p.confidence, False)
        if default is not None:  # Figure 1, dotted: the default controller keeps the robot safe
            return Decision(default[1].y, "unsure", default[0], default[1].confidence, False)
        return Decision(p.y, "unsure", name, p.confidence, False)


class HighestConfidence(TeacherFirst):
    """Whoever is most confident wins; a hesitant new teacher lets a confident student drive."""

    def decide(self, teachers, learner, default, fallback) -> Decision:
        if teachers:
            name, p, y, taught = _teach(teachers, learner, fallback)
            if learner is None or p.confidence >= learner[1].confidence:
                return Decision(y, "teacher", name, p.confidence, True, taught)
        return self._student(learner, default, fallback)


class PredictiveLearning(TeacherFirst):
    """Algorithm 1: the teacher drives and the learner trains until its squared prediction error,
    averaged over `window` ticks, falls under `error_threshold`; then the learner acts for good."""

    def __init__(self, unsure_below: float = 0.25, error_threshold: float = 1e-3, window: int = 50):
        super().__init__(unsure_below)
        self.error_threshold, self.window = error_threshold, window
        self._errors: list[float] = []
        self.acting = False

    def decide(self, teachers, learner, default, fallback) -> Decision:
        if self.acting or not teachers:
            decision = self._student(learner, default, fallback)
            return Decision(decision.y, "student" if self.acting else decision.mode, decision.source,
                            decision.confidence, False)
        name, p, y, taught = _teach(teachers, learner, fallback)
        if learner is not None:
            self._errors = (self._errors + [float(np.mean((learner[1].y - y) ** 2))])[-self.window:]
            if len(self._errors) == self.window and np.mean(self._errors) < self.error_threshold:
                self.acting = True
        return Decision(y, "teacher", name, p.confidence, True, taught)


STRATEGIES = {"teacher-first": TeacherFirst, "confidence": HighestConfidence, "predictive": PredictiveLearning}


def make_strategy(name: str, **params):
    if name not in STRATEGIES:
        raise ValueError(f"unknown arbitration strategy {name!r}; known: {', '.join(STRATEGIES)}")
    return STRATEGIES[name](**params)
