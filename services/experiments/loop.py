"""One tick of Algorithm 2 in a single process, and the trace a run records.

The tick asks the active teachers and the learner, then steps 5 and 6 are the very functions the
arbitrator and learner boxes call over the bus (services.arbitration.algorithm2).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bus_schema import Proposal
from services.arbitration.algorithm2 import decide, learn_pair, trains
from services.arbitration.strategies import Decision, TeacherFirst


def tick(x: np.ndarray, teachers: list, learner, strategy=None, fallback: np.ndarray | None = None,
         index: int = 0, output_space=None, default=None, choice: bool = False) -> tuple[Decision, np.ndarray, float]:
    """Algorithm 2, steps 3-6. `teachers`: (name, teacher) pairs switched on now; `default`: a
    (name, controller) pair, Figure 1's default controller. Returns the decision and the student's
    own prediction (y_hat, confidence) before it learned this tick."""
    strategy = strategy or TeacherFirst()
    predicted = learner.predict_one(x)
    proposals = []
    for name, teacher in teachers:
        y, confidence = teacher(x)
        if y is not None:
            mask = getattr(teacher, "mask", None)
            proposals.append((name, Proposal(index, name, np.asarray(y, dtype=np.float64), float(confidence), mask)))
    student = ("learner/student", Proposal(index, "learner/student", predicted.y, float(predicted.confidence)))
    if fallback is None:
        fallback = np.zeros(learner.n_out)
    if default is not None:
        name, controller = default
        y, confidence = controller(x)
        default = (name, Proposal(index, name, np.asarray(y, dtype=np.float64), float(confidence)))
    decision, _ = decide(strategy, proposals, student, default, fallback, output_space, choice)
    if trains(decision):
        learn_pair(learner, x, decision.y, decision.mask, decision.source)
    return decision, predicted.y, float(predicted.confidence)


@dataclass
class Trace:
    """Per tick: time, input, output sent, the student's prediction and confidence, teacher on, mode."""

    t: list = field(default_factory=list)
    x: list = field(default_factory=list)
    y: list = field(default_factory=list)
    student: list = field(default_factory=list)
    confidence: list = field(default_factory=list)
    teaching: list = field(default_factory=list)
    mode: list = field(default_factory=list)

    def add(self, t: float, x, decision: Decision, student_y, confidence: float) -> None:
        self.t.append(t)
        self.x.append(np.array(x, dtype=np.float64))
        self.y.append(np.array(decision.y, dtype=np.float64))
        self.student.append(np.array(student_y, dtype=np.float64))
        self.confidence.append(confidence)
        self.teaching.append(decision.mode == "teacher")
        self.mode.append(decision.mode)

    def arrays(self) -> dict[str, np.ndarray]:
        return {"t": np.asarray(self.t, dtype=np.float64), "x": np.asarray(self.x), "y": np.asarray(self.y),
                "student": np.asarray(self.student), "confidence": np.asarray(self.confidence),
                "teaching": np.asarray(self.teaching, dtype=bool), "mode": np.asarray(self.mode)}

    def save(self, path: Path) -> None:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(path, **self.arrays())
