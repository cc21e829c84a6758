"""One DL instance of a recorded run as arrays: every input, the command and mode of each tick, the
training pairs in the order they were numbered, and each live learner's answers. A tick is told apart
by its platform's run too (services.recording.restarts): a restarted platform counts from 1 again."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bus_schema import InstanceKeys, SchemaError, Spaces
from services.recording.reader import iter_samples, read_metadata, spaces_in
from services.recording.restarts import PlatformRuns


@dataclass
class LiveAnswers:
    """A live learner's recorded proposals: per (platform run, tick) its output, confidence, pairs learned and
    pairs taken in but not yet learned (it answered those ticks unsure)."""
    ticks: np.ndarray
    runs: np.ndarray
    y: np.ndarray
    confidence: np.ndarray
    learned: np.ndarray
    backlog: np.ndarray


@dataclass
class RecordedRun:
    instance: str
    spaces: Spaces
    ticks: np.ndarray        # (n,) every recorded input's tick, in the order received: by run, ticks rising
    runs: np.ndarray         # (n,) the platform's run each input is of (0, 1, ...; each restart begins one)
    t: np.ndarray            # (n,) seconds since the first input (the platform's stamps)
    x: np.ndarray            # (n, n_in)
    modes: np.ndarray        # (n,) the command's mode at that tick ('' where none was recorded)
    pair_ticks: np.ndarray   # (m,) training pairs in learning order (epochs in turn, seq within)
    pair_runs: np.ndarray    # (m,) the platform's run of each pair's tick
    pair_x: np.ndarray
    pair_y: np.ndarray
    pair_mask: np.ndarray    # (m, n_out) 1 where taught
    pair_sources: np.ndarray  # (m,) who taught each pair (its `source`: teacher/<name>)
    live: dict[str, LiveAnswers] = field(default_factory=dict)
    rejected: int = 0        # recorded samples that did not decode (none from this recorder)
    truncated: list = field(default_factory=list)

    def index_of(self, runs: np.ndarray, ticks: np.ndarray) -> np.ndarray:
        """The index of the recorded input at each (run, tick); -1 where none was recorded."""
        index = {(int(r), int(t)): i for i, (r, t) in enumerate(zip(self.runs, self.ticks))}
        return np.array([index.get((int(r), int(t)), -1) for r, t in zip(runs, ticks)], dtype=np.int64)

    def answered(self, live: str) -> tuple[np.ndarray, np.ndarray]:
        """(indexes into the recorded inputs, indexes into live learner `live`'s answers) of the (run, tick)s
        both hold: an answer whose input was not recorded (a restarted recorder came in after it) is left out."""
        answers = self.live[live]
        where = self.index_of(answers.runs, answers.ticks)
        both = np.flatnonzero(where >= 0)
        return where[both], both

    def pairs_before(self) -> np.ndarray:
        """Per recorded input, how many training pairs are of earlier ticks (earlier runs' all)."""
        counts = np.zeros(len(self.ticks), dtype=np.int64)
        for run in np.unique(self.runs):
            here, own = self.runs == run, np.sort(self.pair_ticks[self.pair_runs == run])
            counts[here] = np.count_nonzero(self.pair_runs < run) + np.searchsorted(own, self.ticks[here])
        return counts

    @property
    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0]) if len(self.t) > 1 else 0.0

    def taught_at_ticks(self) -> np.ndarray:
        """(n, n_out): the teacher's recorded output at each input's tick (its training pair), NaN elsewhere
        (and where a partial teacher did not teach that output)."""
        out = np.full((len(self.ticks), self.spaces.output.dims), np.nan)
        for i, y, mask in zip(self.index_of(self.pair_runs, self.pair_ticks), self.pair_y, self.pair_mask):
            if i >= 0:
                out[i] = np.where(mask == 1, y, np.nan)
        return out


class NoInputs(ValueError):
    """A recording that holds the instance's spaces but none of its inputs: a file a rotation began as the platform
    stopped (its last frames and statuses), say. It reads; there is nothing in it to replay."""


def load_run(run: str | Path, instance: str = "main") -> RecordedRun:
    keys = InstanceKeys(instance)
    spaces_dict = spaces_in(read_metadata(run), instance)
    if spaces_dict is None:
        raise ValueError(f"{run}: no spaces of instance {instance!r} recorded (was its platform up?)")
    spaces = Spaces.from_dict(spaces_dict)
    truncated: list = []
    inputs, others, runs, rejected = _read(run, keys, truncated)
    if not inputs:
        raise NoInputs(f"{run}: the spaces of instance {instance!r} but none of its inputs recorded")
    modes, ordered, live = _placed(others, runs, keys)
    stamps = np.array([msg.stamp for _, msg in inputs])
    n_out = spaces.output.dims
    return RecordedRun(
        instance, spaces, np.array([msg.tick for _, msg in inputs], dtype=np.int64),
        np.array([at for at, _ in inputs], dtype=np.int64), stamps - stamps[0], np.array([msg.x for _, msg in inputs]),
        np.array([modes.get((at, msg.tick), "") for at, msg in inputs]),
        np.array([p.tick for _, p in ordered], dtype=np.int64), np.array([at for at, _ in ordered], dtype=np.int64),
        _rows([p.x for _, p in ordered], spaces.input.dims), _rows([p.y for _, p in ordered], n_out),
        _rows([np.ones(n_out) if p.mask is None else p.mask for _, p in ordered], n_out),
        np.array([p.source for _, p in ordered], dtype=str),
        {name: _answers(msgs) for name, msgs in live.items()}, rejected, truncated)


def _read(run: str | Path, keys: InstanceKeys, truncated: list) -> tuple[list, list, PlatformRuns, int]:
    """The instance's inputs as (run, msg) and its other samples as (key, msg, log_ns, the run current when
    it came), in the order received; the runs they make; how many samples did not decode."""
    inputs, others, runs, rejected = [], [], PlatformRuns(), 0
    for sample in iter_samples(run, truncated=truncated):
        if not sample.key.startswith(keys.prefix + "/"):
            continue
        try:
            msg = sample.decoded()
        except SchemaError:
            rejected += 1
            continue
        if sample.key == keys.input:
            inputs.append((runs.add_input(msg.tick, sample.log_ns), msg))
        elif sample.key in (keys.command, keys.train) or sample.key.startswith(keys.proposal("learner", "")):
            others.append((sample.key, msg, sample.log_ns, runs.current))
    return inputs, others, runs, rejected


def _placed(others: list, runs: PlatformRuns, keys: InstanceKeys) -> tuple[dict, list, dict]:
    """Each sample at its (run, tick): the modes of the commands, the training pairs as (run, pair) in
    learning order, each live learner's answers as (run, proposal)."""
    modes, pairs, live, epochs = {}, {}, {}, []
    learner_prefix = keys.proposal("learner", "")
    for key, msg, log_ns, received_in in others:
        at = runs.run_of(msg.tick, log_ns, received_in)
        if key == keys.command:
            modes[(at, msg.tick)] = msg.mode
        elif key == keys.train:
            if msg.epoch not in epochs:
                epochs.append(msg.epoch)
            pairs[(epochs.index(msg.epoch), msg.seq)] = (at, msg)
        else:
            live.setdefault(key[len(learner_prefix):], []).append((at, msg))
    return modes, [pairs[k] for k in sorted(pairs)], live


def _rows(vectors: list, width: int) -> np.ndarray:
    return np.array(vectors, dtype=np.float64).reshape(-1, width)


def _answers(proposals: list) -> LiveAnswers:
    by_position = {(at, p.tick): p for at, p in proposals}  # a tick answered twice (never, live) keeps the last
    order = sorted(by_position)
    answers = [by_position[k] for k in order]
    return LiveAnswers(np.array([tick for _, tick in order], dtype=np.int64),
                       np.array([at for at, _ in order], dtype=np.int64), np.array([p.y for p in answers]),
                       np.array([p.confidence for p in answers]), np.array([p.learned for p in answers]),
                       np.array([p.backlog for p in answers], dtype=np.int64))
