"""A recorded run played back as a platform (`dogged play`): each tick's input is the next one recorded,
whatever is commanded, so a new learner, arbitrator or teacher meets real experience with everything
else live. Its spaces are the recorded ones. Commands are clipped and reported, and change nothing."""
from __future__ import annotations

import numpy as np

from bus_schema.spaces import Spaces
from services.recording.reader import iter_samples, read_metadata, spaces_in


class RecordedPlatform:
    def __init__(self, run: str = "", instance: str = "main", loop: bool = False, seed: int = 0):
        if not run:
            raise ValueError("run: required (a recorder's folder or one of its .mcap files)")
        spaces = spaces_in(read_metadata(run), instance)
        if spaces is None:
            raise ValueError(f"run: {run} holds no spaces of instance {instance!r}")
        self.spaces = Spaces.from_dict(spaces)
        key = f"dl/{instance}/input"
        inputs = {}
        for sample in iter_samples(run, {key}):
            msg = sample.decoded()
            inputs[msg.tick] = (msg.stamp, msg.x)
        if not inputs:
            raise ValueError(f"run: {run} holds no inputs of instance {instance!r}")
        ticks = sorted(inputs)
        self.x = np.array([inputs[t][1] for t in ticks])
        stamps = np.array([inputs[t][0] for t in ticks])
        self.recorded_hz = float(1.0 / np.median(np.diff(stamps))) if len(stamps) > 1 else 30.0
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
