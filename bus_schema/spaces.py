"""Spaces declared as data: what a platform takes and gives (dims, bounds, names, units)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Box:
    """A bounded box of float64 values; `names` and `units` label each dimension."""

    low: tuple[float, ...]
    high: tuple[float, ...]
    names: tuple[str, ...] = ()
    units: tuple[str, ...] = ()

    def __post_init__(self):
        n = len(self.low)
        if n == 0 or len(self.high) != n:
            raise ValueError(f"Box needs as many low as high bounds (got {len(self.low)} and {len(self.high)})")
        if any(not lo <= hi for lo, hi in zip(self.low, self.high)):
            raise ValueError("Box bounds must satisfy low <= high in every dimension")
        for label, values in (("names", self.names), ("units", self.units)):
            if values and len(values) != n:
                raise ValueError(f"Box {label} has {len(values)} entries for {n} dimensions")

    @property
    def dims(self) -> int:
        return len(self.low)

    def clip(self, values: np.ndarray) -> np.ndarray:
        return np.clip(values, self.low, self.high)

    def contains(self, values: np.ndarray, tol: float = 1e-9) -> bool:
        v = np.asarray(values, dtype=np.float64)
        low, high = np.asarray(self.low) - tol, np.asarray(self.high) + tol
        return v.shape == (self.dims,) and bool(np.all(v >= low) and np.all(v <= high))

    @classmethod
    def uniform(cls, dims: int, low: float, high: float, name: str = "x", unit: str = "") -> Box:
        names = tuple(f"{name}{i}" for i in range(dims))
        return cls((low,) * dims, (high,) * dims, names, (unit,) * dims if unit else ())

    def to_dict(self) -> dict:
        return {"low": list(self.low), "high": list(self.high), "names": list(self.names), "units": list(self.units)}

    @classmethod
    def from_dict(cls, d: dict) -> Box:
        return cls(tuple(map(float, d["low"])), tuple(map(float, d["high"])), tuple(d.get("names", ())),
                   tuple(d.get("units", ())))


@dataclass(frozen=True)
class Spaces:
    """The input a platform gives to DL and the output (command) it accepts."""

    input: Box
    output: Box
    extra: dict = field(default_factory=dict)  # free-form facts (rates, camera size) for humans and tools

    def to_dict(self) -> dict:
        return {"input": self.input.to_dict(), "output": self.output.to_dict(), "extra": dict(self.extra)}

    @classmethod
    def from_dict(cls, d: dict) -> Spaces:
        return cls(Box.from_dict(d["input"]), Box.from_dict(d["output"]), dict(d.get("extra", {})))


LOCKSTEP = "lockstep"  # extra: true when the platform steps only once its tick is answered (--rate 0)


def announced(spaces: Spaces, rate_hz: float) -> Spaces:
    """The spaces as a platform announces them: marked `lockstep` when it runs at rate 0, and not otherwise
    (a recorded run's spaces, played back at a rate, may say lockstep from when it was recorded)."""
    return marked(spaces, not rate_hz)


def paced_like(spaces: Spaces, source: Spaces) -> Spaces:
    """A box's spaces derived from a platform's (`source`): in lockstep when the platform is."""
    return marked(spaces, in_lockstep(source))


def marked(spaces: Spaces, lockstep: bool) -> Spaces:
    extra = {k: v for k, v in spaces.extra.items() if k != LOCKSTEP}
    return Spaces(spaces.input, spaces.output, {**extra, LOCKSTEP: True} if lockstep else extra)


def in_lockstep(spaces: Spaces) -> bool:
    """Whether the loop's platform steps only once answered (only a literal true says so)."""
    return spaces.extra.get(LOCKSTEP) is True
