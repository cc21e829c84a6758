"""The benchmark tasks, shared by tests and benchmarks/learners.py (data, not the library).

`cross` is the 2-D function of the LWPR tutorial; `mirror` is the paper's first Aibo task
(head copies tail; indices follow the project's joint order: 12 head_tilt, 13 head_pan,
16 tail_tilt, 17 tail_pan).
"""
from __future__ import annotations

import numpy as np

HEAD_TILT, HEAD_PAN, TAIL_TILT, TAIL_PAN = 12, 13, 16, 17
N_JOINTS = 18

# the LWPR tutorial's settings for cross: full metric with meta-learned rates
CROSS_LWPR_PARAMS = {"init_D": 25.0, "init_alpha": 250.0, "w_gen": 0.2, "diag_only": False, "meta": True}


def cross(xs: np.ndarray) -> np.ndarray:
    """max(exp(-10 x1^2), exp(-50 x2^2), 1.25 exp(-5 (x1^2 + x2^2))), shape (n, 1)."""
    x1, x2 = xs[:, 0], xs[:, 1]
    value = np.maximum.reduce([np.exp(-10 * x1 ** 2), np.exp(-50 * x2 ** 2), 1.25 * np.exp(-5 * (x1 ** 2 + x2 ** 2))])
    return value[:, None]


def cross_training(n: int = 500, noise: float = 0.1, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    xs = rng.uniform(-1.0, 1.0, (n, 2))
    return xs, cross(xs) + rng.normal(0.0, noise, (n, 1))


def cross_grid(points: int = 41) -> tuple[np.ndarray, np.ndarray]:
    """The noise-free test grid."""
    axis = np.linspace(-1.0, 1.0, points)
    xs = np.array([[a, b] for a in axis for b in axis])
    return xs, cross(xs)


def mirror(xs: np.ndarray) -> np.ndarray:
    ys = np.zeros_like(xs)
    ys[:, HEAD_TILT] = xs[:, TAIL_TILT]
    ys[:, HEAD_PAN] = xs[:, TAIL_PAN]
    return ys


def mirror_samples(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    xs = np.random.default_rng(seed).uniform(-1.0, 1.0, (n, N_JOINTS))
    return xs, mirror(xs)


def nmse(predicted: np.ndarray, truth: np.ndarray) -> float:
    """Mean squared error over the variance of the truth, averaged over outputs."""
    truth = truth.reshape(len(truth), -1)
    error = (predicted.reshape(truth.shape) - truth) ** 2
    return float(np.mean(error.mean(axis=0) / truth.var(axis=0)))


def worst_error(predicted: np.ndarray, truth: np.ndarray) -> float:
    return float(np.max(np.abs(predicted - truth)))


def cross_embedded(n: int, dims: int = 10, noise: float = 0.1, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Cross on the first two of `dims` uniform inputs; the others are irrelevant (as in
    Vijayakumar et al. 2005, section 4). Targets carry N(0, noise^2)."""
    rng = np.random.default_rng(seed)
    xs = rng.uniform(-1.0, 1.0, (n, dims))
    return xs, cross(xs[:, :2]) + rng.normal(0.0, noise, (n, 1))


def three_outputs(xs: np.ndarray) -> np.ndarray:
    """A 3-output map of 12 inputs, each output using different ones (7 used by none)."""
    return np.stack([np.sin(2 * xs[:, 0]) + xs[:, 1], xs[:, 2] * xs[:, 3], np.exp(-2 * xs[:, 4] ** 2)], axis=1)


def three_outputs_samples(n: int, noise: float = 0.02, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    xs = rng.uniform(-1.0, 1.0, (n, 12))
    return xs, three_outputs(xs) + rng.normal(0.0, noise, (n, 3))
