"""Tasks nobody tuned for: random smooth nonlinear maps of a few inputs among many, taught on
streams that move like a robot's joints (or drawn i.i.d., the easy second case).

    task = draw_task(seed, in_low, in_high, out_low, out_high)
    xs = task.stream(seconds=90.0, rate=30.0, kind="trajectory")   # (n, n_in), smooth in time
    ys = task.target(xs)                                            # (n, n_out)
    task.relevant, task.taught                                      # inputs that matter, outputs taught

Each taught output is a random sum of sinusoids or a random small tanh network of 2-4 random
inputs, scaled to span `span` (1.3 by default, a head joint's range) and redrawn until its slope is
bounded; every other input moves as a distractor, some of them following a relevant input (the
nearly collinear data a robot gives: a reading that echoes a command, a joint dragged along).
Untaught outputs hold the middle of their range. A task is a pure function of its seed.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_SLOPE = 3.0  # of a target, output half-spans per input half-range (a straight line is 1)
SENSOR_NOISE = 0.002  # reading noise, as a share of each input's range


@dataclass(frozen=True)
class Motion:
    """How one input moves: around `centre` within +-`amplitude`, by sines or waypoints,
    or following input `leader` with weight `follow` (0: its own motion only)."""

    kind: str
    centre: float
    amplitude: float
    periods: tuple[float, ...]
    phases: tuple[float, ...]
    leader: int = -1
    follow: float = 0.0


@dataclass(frozen=True)
class Target:
    """One output's map g(u) of the relevant inputs u (in [-1, 1] over each one's moving range)."""

    kind: str  # sines | network
    weights: np.ndarray  # sines: (terms, r) frequencies; network: (hidden, r) input weights
    offsets: np.ndarray  # phases or biases
    gains: np.ndarray  # amplitudes or output weights
    low: float  # g's span on the cube, for scaling to [-1, 1]
    high: float

    def raw(self, u: np.ndarray) -> np.ndarray:
        z = u @ self.weights.T + self.offsets
        return (np.sin(z) if self.kind == "sines" else np.tanh(z)) @ self.gains

    def __call__(self, u: np.ndarray) -> np.ndarray:
        return 2.0 * (self.raw(u) - self.low) / (self.high - self.low) - 1.0


@dataclass(frozen=True)
class UnknownTask:
    seed: int
    in_low: np.ndarray
    in_high: np.ndarray
    relevant: tuple[int, ...]
    taught: tuple[int, ...]
    motions: tuple[Motion, ...]
    targets: tuple[Target, ...]  # one per taught output
    centres: np.ndarray  # (n_out,) middle of each output's targets (the held value when untaught)
    half_spans: np.ndarray  # (n_out,) half the span of each taught output's targets

    @property
    def n_in(self) -> int:
        return len(self.in_low)

    @property
    def n_out(self) -> int:
        return len(self.centres)

    def target(self, xs: np.ndarray) -> np.ndarray:
        xs = np.atleast_2d(xs)
        relevant = list(self.relevant)
        centre = np.array([self.motions[i].centre for i in relevant])
        amplitude = np.array([self.motions[i].amplitude for i in relevant])
        u = (xs[:, relevant] - centre) / amplitude
        ys = np.tile(self.centres, (len(xs), 1))
        for output, g in zip(self.taught, self.targets):
            ys[:, output] += self.half_spans[output] * g(u)
        return ys

    def mask(self) -> np.ndarray:
        mask = np.zeros(self.n_out)
        mask[list(self.taught)] = 1.0
        return mask

    def stream(self, seconds: float, rate: float = 30.0, kind: str = "trajectory", seed: int = 0) -> np.ndarray:
        """Inputs at `rate` for `seconds`: a trajectory is a pure function of time (its first
        n rows are the same whatever `seconds`); i.i.d. rows are uniform over each input's motion box."""
        n = int(round(seconds * rate))
        rng = np.random.default_rng([self.seed, 3, seed])
        if kind == "iid":
            xs = np.array([[m.centre + m.amplitude * rng.uniform(-1.0, 1.0) for m in self.motions] for _ in range(n)])
        elif kind == "trajectory":
            t = np.arange(n) / rate
            xs = np.stack([own_motion(m, t, [self.seed, 5, seed, i]) for i, m in enumerate(self.motions)], axis=1)
            for i, m in enumerate(self.motions):
                if m.leader >= 0:
                    lead = self.motions[m.leader]
                    dragged = m.amplitude * (xs[:, m.leader] - lead.centre) / lead.amplitude
                    xs[:, i] = m.centre + m.follow * dragged + (1.0 - abs(m.follow)) * (xs[:, i] - m.centre)
        else:
            raise ValueError(f"kind must be 'trajectory' or 'iid', got {kind!r}")
        noise = SENSOR_NOISE * (self.in_high - self.in_low)
        xs = xs + rng.normal(0.0, 1.0, xs.shape) * noise
        return np.clip(xs, self.in_low, self.in_high)


def own_motion(m: Motion, t: np.ndarray, seed) -> np.ndarray:
    """An input's own smooth path: two sines at incommensurate periods, or cosine-blended
    random waypoints every periods[0] seconds (a handler's hand)."""
    if m.kind == "sines":
        wave = sum(np.sin(2 * np.pi * t / p + phase) for p, phase in zip(m.periods, m.phases)) / len(m.periods)
        return m.centre + m.amplitude * wave
    segment = m.periods[0]
    k, s = np.divmod(t / segment, 1.0)
    k = k.astype(int)
    points = np.random.default_rng(seed).uniform(-1.0, 1.0, int(k.max(initial=0)) + 2)
    blend = (1 - np.cos(np.pi * s)) / 2
    return m.centre + m.amplitude * ((1 - blend) * points[k] + blend * points[k + 1])


def draw_motion(rng: np.random.Generator, low: float, high: float) -> Motion:
    half = (high - low) / 2
    amplitude = half * rng.uniform(0.5, 0.95)
    centre = (low + high) / 2 + rng.uniform(-1.0, 1.0) * (half - amplitude)
    if rng.random() < 0.5:
        return Motion("sines", centre, amplitude, tuple(rng.uniform(3.0, 12.0, 2)), tuple(rng.uniform(0, 2 * np.pi, 2)))
    return Motion("waypoints", centre, amplitude, (float(rng.uniform(0.7, 3.0)),), ())


def draw_target(rng: np.random.Generator, r: int) -> Target:
    """A smooth map of r inputs whose slope is at most MAX_SLOPE, redrawn until it is."""
    probe = rng.uniform(-1.0, 1.0, (4000, r))
    while True:
        if rng.random() < 0.5:
            terms = int(rng.integers(2, 5))
            directions = rng.normal(size=(terms, r))
            directions /= np.linalg.norm(directions, axis=1, keepdims=True)
            target = Target("sines", directions * rng.uniform(0.5, 3.0, (terms, 1)), rng.uniform(0, 2 * np.pi, terms),
                            rng.uniform(0.3, 1.0, terms) * rng.choice([-1.0, 1.0], terms), 0.0, 1.0)
        else:
            hidden = int(rng.integers(2, 7))
            target = Target("network", rng.normal(0.0, 1.5, (hidden, r)), rng.normal(0.0, 0.5, hidden),
                            rng.normal(0.0, 1.0, hidden), 0.0, 1.0)
        values = target.raw(probe)
        low, high = float(values.min()), float(values.max())
        if high - low < 1e-6:
            continue
        scaled = Target(target.kind, target.weights, target.offsets, target.gains, low, high)
        if max_slope(scaled, probe) <= MAX_SLOPE:
            return scaled


def max_slope(g: Target, u: np.ndarray, h: float = 1e-4) -> float:
    grads = np.stack([(g(u + h * e) - g(u - h * e)) / (2 * h) for e in np.eye(u.shape[1])], axis=1)
    return float(np.linalg.norm(grads, axis=1).max())


def draw_task(seed: int, in_low, in_high, out_low, out_high, relevant: tuple[int, int] = (2, 4),
              taught: tuple[int, int] = (1, 3), span: float = 1.3, followers: float = 0.3) -> UnknownTask:
    """A random task on the given input and output boxes: `relevant` and `taught` are (fewest, most)."""
    in_low, in_high = np.asarray(in_low, dtype=np.float64), np.asarray(in_high, dtype=np.float64)
    out_low, out_high = np.asarray(out_low, dtype=np.float64), np.asarray(out_high, dtype=np.float64)
    rng = np.random.default_rng([seed, 1])
    n_in, n_out = len(in_low), len(out_low)
    chosen = tuple(sorted(rng.choice(n_in, int(rng.integers(relevant[0], min(relevant[1], n_in) + 1)), replace=False)))
    outputs = tuple(sorted(rng.choice(n_out, int(rng.integers(taught[0], min(taught[1], n_out) + 1)), replace=False)))
    motions = [draw_motion(rng, lo, hi) for lo, hi in zip(in_low, in_high)]
    for i in range(n_in):
        if i not in chosen and rng.random() < followers:
            m = motions[i]
            follow = float(rng.uniform(0.5, 0.95) * rng.choice([-1.0, 1.0]))
            motions[i] = Motion(m.kind, m.centre, m.amplitude, m.periods, m.phases, int(rng.choice(chosen)), follow)
    half_spans = np.minimum(span, 0.9 * (out_high - out_low)) / 2
    centres = (out_low + out_high) / 2 + rng.uniform(-1.0, 1.0, n_out) * np.maximum(
        0.0, (out_high - out_low) / 2 - half_spans)
    targets = tuple(draw_target(rng, len(chosen)) for _ in outputs)
    return UnknownTask(seed, in_low, in_high, chosen, outputs, tuple(motions), targets, centres, half_spans)
