"""One DL instance of a recorded run as arrays: every input, the command and mode of each tick, the
training pairs in the order they were numbered, and each live learner's answers."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bus_schema import InstanceKeys, SchemaError, Spaces
from services.recording.reader import iter_samples, read_metadata, spaces_in


@dataclass
class LiveAnswers:
    """A live learner's recorded proposals: per tick its output, confidence and pairs learned."""
    ticks: np.ndarray
    y: np.ndarray
    confidence: np.ndarray
    learned: np.ndarray


@dataclass
class RecordedRun:
    instance: str
    spaces: Spaces
    ticks: np.ndarray        # (n,) every recorded input's tick, in tick order
    t: np.ndarray            # (n,) seconds since the first input (the platform's stamps)
    x: np.ndarray            # (n, n_in)
    modes: np.ndarray        # (n,) the command's mode at that tick ('' where none was recorded)
    pair_ticks: np.ndarray   # (m,) training pairs in learning order (epochs in turn, seq within)
    pair_x: np.ndarray
    pair_y: np.ndarray
    pair_mask: np.ndarray    # (m, n_out) 1 where taught
    live: dict[str, LiveAnswers] = field(default_factory=dict)
    rejected: int = 0        # recorded samples that did not decode (none from this recorder)
    truncated: list = field(default_factory=list)

    def answered(self, live: str) -> tuple[np.ndarray, np.ndarray]:
        """(indexes into the recorded inputs, indexes into live learner `live`'s answers) of the ticks both
        hold: an answer whose input was not recorded (a restarted recorder came in after it) is left out."""
        answers = self.live[live]
        where = np.searchsorted(self.ticks, answers.ticks).clip(0, max(len(self.ticks) - 1, 0))
        both = np.flatnonzero(self.ticks[where] == answers.ticks) if len(self.ticks) else np.array([], int)
        return where[both], both

    @property
    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0]) if len(self.t) > 1 else 0.0

    def taught_at_ticks(self) -> np.ndarray:
        """(n, n_out): the teacher's recorded output at each input's tick (its training pair), NaN elsewhere
        (and where a partial teacher did not teach that output)."""
        out = np.full((len(self.ticks), self.spaces.output.dims), np.nan)
        index = {int(t): i for i, t in enumerate(self.ticks)}
        for tick, y, mask in zip(self.pair_ticks, self.pair_y, self.pair_mask):
            i = index.get(int(tick))
            if i is not None:
                out[i] = np.where(mask == 1, y, np.nan)
        return out


def load_run(run: str | Path, instance: str = "main") -> RecordedRun:
    keys = InstanceKeys(instance)
    spaces_dict = spaces_in(read_metadata(run), instance)
    if spaces_dict is None:
        raise ValueError(f"{run}: no spaces of instance {instance!r} recorded (was its platform up?)")
    spaces = Spaces.from_dict(spaces_dict)
    inputs, modes, pairs, live, truncated, rejected = {}, {}, {}, {}, [], 0
    epochs: list[str] = []
    learner_prefix = keys.proposal("learner", "")
    for sample in iter_samples(run, truncated=truncated):
        if not (sample.key.startswith(keys.prefix + "/")):
            continue
        try:
            msg = sample.decoded()
        except SchemaError:
            rejected += 1
            continue
        if sample.key == keys.input:
            inputs[msg.tick] = msg
        elif sample.key == keys.command:
            modes[msg.tick] = msg.mode
        elif sample.key == keys.train:
            if msg.epoch not in epochs:
                epochs.append(msg.epoch)
            pairs[(epochs.index(msg.epoch), msg.seq)] = msg
        elif sample.key.startswith(learner_prefix):
            live.setdefault(sample.key[len(learner_prefix):], []).append(msg)
    if not inputs:
        raise ValueError(f"{run}: no inputs of instance {instance!r} recorded")
    ticks = np.array(sorted(inputs))
    stamps = np.array([inputs[t].stamp for t in ticks])
    ordered = [pairs[k] for k in sorted(pairs)]
    n_out = spaces.output.dims
    return RecordedRun(
        instance, spaces, ticks, stamps - stamps[0], np.array([inputs[t].x for t in ticks]),
        np.array([modes.get(int(t), "") for t in ticks]),
        np.array([p.tick for p in ordered], dtype=np.int64), _rows([p.x for p in ordered], spaces.input.dims),
        _rows([p.y for p in ordered], n_out),
        _rows([np.ones(n_out) if p.mask is None else p.mask for p in ordered], n_out),
        {name: _answers(msgs) for name, msgs in live.items()}, rejected, truncated)


def _rows(vectors: list, width: int) -> np.ndarray:
    return np.array(vectors, dtype=np.float64).reshape(-1, width)


def _answers(proposals: list) -> LiveAnswers:
    by_tick = {p.tick: p for p in proposals}  # a tick answered twice (never, live) keeps the last
    ticks = np.array(sorted(by_tick))
    return LiveAnswers(ticks, np.array([by_tick[t].y for t in ticks]),
                       np.array([by_tick[t].confidence for t in ticks]), np.array([by_tick[t].learned for t in ticks]))
