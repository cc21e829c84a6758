"""Doubt about inputs beyond experience, for learners whose own confidence cannot see it.

A kernel's width is shared by every input, so a value never seen along one input that never
varied (an orange ball after teaching with pink alone) barely moves a GP's variance or a
neighbour's distance: the robot would drive on, sure of itself, where it should ask. The
envelope keeps each input's mean and spread over everything learned; a query's confidence is
multiplied by exp(-d^2 / (2 scale^2)), d being how far it lies beyond mean +- EXPERIENCED_SDS
sd. LWPR does the same per receptive field (lwpr_layout.beyond_experience).
"""
from __future__ import annotations

import numpy as np

# an input has been seen within this many standard deviations of its mean
EXPERIENCED_SDS = 3.0


class InputEnvelope:
    """Per-input running mean and variance of the inputs learned (Chan's batch merge)."""

    def __init__(self, n_in: int):
        self.count = 0
        self.mean = np.zeros(n_in)
        self.sum_sq = np.zeros(n_in)  # sum of squared deviations from the mean

    def learn(self, xs: np.ndarray) -> None:
        n = xs.shape[0]
        if n == 0:
            return
        batch_mean = xs.mean(axis=0)
        batch_sum_sq = ((xs - batch_mean) ** 2).sum(axis=0)
        total = self.count + n
        delta = batch_mean - self.mean
        self.sum_sq += batch_sum_sq + delta * delta * self.count * n / total
        self.mean += delta * n / total
        self.count = total

    def discount(self, xs: np.ndarray, scale: float, inputs: np.ndarray | None = None) -> np.ndarray:
        """Per row of xs, the factor in (0, 1] its confidence is multiplied by (1: within
        experience, or scale 0: novelty off); `inputs` (a mask) limits it to those inputs."""
        if scale <= 0.0 or self.count == 0:
            return np.ones(xs.shape[0])
        sd = np.sqrt(self.sum_sq / self.count)
        excess = np.maximum(np.abs(xs - self.mean) - EXPERIENCED_SDS * sd, 0.0)
        if inputs is not None:
            excess = excess[:, inputs]
        return np.exp(-0.5 * (excess * excess).sum(axis=1) / (scale * scale))
