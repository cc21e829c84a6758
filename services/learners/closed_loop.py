"""A closed-loop task for the learner checks: the student's own answers choose its next inputs.

A pendulum swung up and balanced by two motors on its joint (3 inputs: cos, sin and rate of the angle
from upright; 2 outputs: each motor's torque, +-1 Nm), the physics of Gymnasium's Pendulum-v1 in a few
lines so the checks need nothing but numpy. The teacher pumps energy and catches the pendulum at the
top, its torque shared by the motors; a student is judged alone, from the same starts, by its mean
return scaled between a random policy's (0) and the teacher's (1).
"""
from __future__ import annotations

import math

import numpy as np

DT, MAX_RATE, MAX_TORQUE, STEPS = 0.05, 8.0, 1.0, 200  # per motor: two make the task's 2 Nm
GRAVITY_TERM, TORQUE_GAIN = 15.0, 3.0  # theta'' = 3 g / (2 l) sin(theta) + 3 u / (m l^2), g = 10, m = l = 1


def observe(theta: float, rate: float) -> np.ndarray:
    return np.array([math.cos(theta), math.sin(theta), rate])


def step(theta: float, rate: float, torques: np.ndarray) -> tuple[float, float, float]:
    """One step of the pendulum under the motors' torques (clipped to +-MAX_TORQUE): (theta, rate, reward)."""
    u = float(np.clip(torques, -MAX_TORQUE, MAX_TORQUE).sum())
    wrapped = (theta + math.pi) % (2 * math.pi) - math.pi
    reward = -(wrapped ** 2 + 0.1 * rate ** 2 + 0.001 * u ** 2)
    rate = min(max(rate + (GRAVITY_TERM * math.sin(theta) + TORQUE_GAIN * u) * DT, -MAX_RATE), MAX_RATE)
    return theta + rate * DT, rate, reward


def teacher(x: np.ndarray) -> np.ndarray:
    """Energy pumping below the upright's energy, a PD catch within 0.6 rad of the top: each motor half."""
    cos_t, sin_t, rate = (float(v) for v in x)
    theta = math.atan2(sin_t, cos_t)
    if abs(theta) < 0.6:
        u = -(10.0 * theta + 2.5 * rate)
    else:
        energy = 0.5 * rate * rate + GRAVITY_TERM * (cos_t - 1.0)
        u = -0.5 * energy * rate if rate != 0.0 else 2.0 * MAX_TORQUE
    return np.clip(np.full(2, u / 2.0), -MAX_TORQUE, MAX_TORQUE)


def starts(count: int, seed: int) -> np.ndarray:
    """(theta, rate) at the start of each episode: anywhere, nearly still."""
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-math.pi, math.pi, count), rng.uniform(-1.0, 1.0, count)])


def episode_returns(policy, begin: np.ndarray) -> np.ndarray:
    """The return of `policy(x) -> torques` over STEPS from each start."""
    returns = []
    for theta, rate in begin:
        total = 0.0
        for _ in range(STEPS):
            theta, rate, reward = step(theta, rate, policy(observe(theta, rate)))
            total += reward
        returns.append(total)
    return np.array(returns)


def teach(model, ticks: int, seed: int) -> None:
    """The teacher drives for `ticks` and the model learns every pair; an episode is STEPS long and
    starts where `starts(..., seed)` says."""
    begin = starts(ticks // STEPS + 1, seed)
    for t in range(ticks):
        if t % STEPS == 0:
            theta, rate = begin[t // STEPS]
        x = observe(theta, rate)
        y = teacher(x)
        model.learn_one(x, y)
        theta, rate, _ = step(theta, rate, y)


def score(model, episodes: int = 6, seed: int = 1000) -> float:
    """The student alone, scaled: 0 a random policy's mean return, 1 the teacher's, same starts."""
    begin = starts(episodes, seed)
    rng = np.random.default_rng(seed)
    random = episode_returns(lambda x: rng.uniform(-MAX_TORQUE, MAX_TORQUE, 2), begin).mean()
    best = episode_returns(teacher, begin).mean()
    student = episode_returns(lambda x: model.predict_one(x).y, begin).mean()
    return float((student - random) / (best - random))
