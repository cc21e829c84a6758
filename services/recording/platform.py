"""A recorded run played back as a platform (`dogged play`): each tick's input is the next one recorded,
whatever is commanded, so a new learner, arbitrator or teacher meets real experience with everything
else live. Every recorded input is played, in the order recorded, those of each run of a platform that
restarted (counting its ticks from 1 again) in turn. Its spaces are the recorded ones. Commands are
clipped and reported, and change nothing."""
from __future__ import annotations

import numpy as np

from bus_schema.spaces import Spaces
from services.recording.reader import iter_samples, read_metadata, spaces_in
from services.recording.restarts import runs_of_inputs


class RecordedPlatform:
    def __init__(self, run: str = "", instance: str = "main", loop: bool = False, seed: int = 0):
        if not run:
            raise ValueError("run: required (a recorder's folder or one of its .mcap files)")
        spaces = spaces_in(read_metadata(run), instance)
        if spaces is None:
            raise ValueError(f"run: {run} holds no spaces of instance {instance!r}")
        self.spaces = Spaces.from_dict(spaces)
        key = f"dl/{instance}/input"
        inputs = [(sample.decoded(), sample.log_ns) for sample in iter_samples(run, {key})]
        if not inputs:
            raise ValueError(f"run: {run} holds no inputs of instance {instance!r}")
        self.x = np.array([msg.x for msg, _ in inputs])
        runs = runs_of_inputs([msg.tick for msg, _ in inputs], [log_ns for _, log_ns in inputs])
        self.recorded_hz = _rate(np.array([msg.stamp for msg, _ in inputs]), runs)
        self.loop, self._i = bool(loop), 0
        self.reset(seed)

    def __len__(self) -> int:
        return len(self.x)

    def reset(self, seed: int | None = None) -> np.ndarray:
        self._i = 0
        return self.observe()

    def observe(self) -> np.ndarray:
        return self.x[self._i].copy()

    def _advance(self) -> None:
        self._i = (self._i + 1) % len(self.x) if self.loop else min(self._i + 1, len(self.x) - 1)

    def step(self, command: np.ndarray, dt: float) -> np.ndarray:
        applied = self.spaces.output.clip(np.asarray(command, dtype=np.float64))
        self._advance()
        return applied

    def hold(self, dt: float) -> None:
        self._advance()  # the recording goes on

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _rate(stamps: np.ndarray, runs: np.ndarray) -> float:
    """Inputs per second of the platform: the median step between inputs of one run (30 if none)."""
    steps = np.diff(stamps)[runs[1:] == runs[:-1]]
    return float(1.0 / np.median(steps)) if len(steps) else 30.0
