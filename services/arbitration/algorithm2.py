"""Algorithm 2, steps 5 and 6, written once: the arbitrator and learner boxes call these over the bus,
the in-process experiments (services.experiments.loop) call them directly.

Step 5: the strategy picks the output, clipped to the output space (every command, and so every pair
learned, is). Step 6: the learner trains on the pair when a teacher spoke (or on every pair with
train_on "all", the algorithm taken literally); a partial teacher's pair trains only the outputs it
taught, where the learner can do that.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from services.arbitration.strategies import Decision


def decide(strategy, teachers, learner, default, fallback: np.ndarray, output_space=None,
           choice: bool = False) -> tuple[Decision, bool]:
    """The strategy's decision with its output clipped to `output_space` (a Box, or None), and whether
    clipping changed it. Where the outputs are a choice (one per action, the largest taken: the spaces'
    extra "choice" is "largest"), a teacher's output becomes the one-hot of the action it chose, as the
    platform applies it, so the student learns the choice, not how a person's stick happened to lean."""
    decision = strategy.decide(teachers, learner, default, fallback)
    if choice and decision.mode == "teacher" and decision.mask is None:
        chosen = np.zeros(len(decision.y))
        chosen[int(np.argmax(decision.y))] = 1.0
        decision = dataclasses.replace(decision, y=chosen)
    if output_space is None:
        return decision, False
    y = output_space.clip(decision.y)
    if np.array_equal(y, decision.y):
        return decision, False
    return dataclasses.replace(decision, y=y), True


def trains(decision: Decision, train_on: str = "teacher") -> bool:
    """Whether the tick's (x, y) goes to the learners."""
    return decision.train or train_on == "all"


def learn_pair(model, x, y, mask=None, source: str | None = None) -> bool:
    """The learner's share of step 6, told who taught the pair where it `learns_sources`. False when a
    partial pair had to be learned whole (the learner takes no mask: see docs/results.md, use per-output)."""
    partial = mask is not None and not np.all(mask == 1)
    told = {"source": source} if source is not None and getattr(model, "learns_sources", False) else {}
    if partial and getattr(model, "accepts_mask", False):
        model.learn_one(x, y, mask=mask, **told)
        return True
    model.learn_one(x, y, **told)
    return not partial
