"""Every training pair a learner has incorporated, in an append-only file; memory holds only their count.

The file is a stream of msgpack TrainingPair payloads; a crash can cut the last record short, so
replay stops where the last record is incomplete and truncates the file there. A whole record that is
not a pair this learner can learn (other dimensions: the spaces changed, or were answered by someone
else) is a PairLogError, and the file is left as it is: nothing a learner was taught is thrown away.
A learner with no state directory keeps its pairs in a temporary file that goes when it does: a
replacement (hot-swap) can still learn them all, and hours of teaching cost disk, not memory.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import msgpack
import numpy as np

from bus_schema import SchemaError, TrainingPair, decode, encode


class PairLogError(RuntimeError):
    """A pair log this learner cannot replay; the file is untouched."""


class PairLog:
    def __init__(self, n_in: int, n_out: int, path: str | os.PathLike | None = None):
        self.n_in, self.n_out = n_in, n_out
        self._scratch = None if path else tempfile.TemporaryDirectory(prefix="dogged-pairs-")
        self.path = Path(path) if path else Path(self._scratch.name) / "pairs"
        self._n = 0
        self._file = None if path else open(self.path, "ab")

    @property
    def durable(self) -> bool:
        """A file of the learner's state dir, flushed after every pair: a crash loses at most a torn record."""
        return self._scratch is None

    def __len__(self) -> int:
        return self._n

    def append(self, pair: TrainingPair) -> None:
        self._file.write(encode(pair))
        if self.durable:
            self._file.flush()
        self._n += 1

    def history(self, n: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The first n pairs (all by default) as (x, y, mask) rows, read back from the file."""
        n = self._n if n is None else min(n, self._n)
        self._file.flush()
        x, y, mask = np.empty((n, self.n_in)), np.empty((n, self.n_out)), np.ones((n, self.n_out))
        with open(self.path, "rb") as f:
            unpacker = msgpack.Unpacker(f, raw=False)
            for row in range(n):
                pair = self._pair(next(unpacker), row + 1)
                x[row], y[row] = pair.x, pair.y
                if pair.mask is not None:
                    mask[row] = pair.mask
        return x, y, mask

    def replay_file(self) -> list[TrainingPair]:
        """Pairs saved by an earlier run of this learner (it crashed or was restarted); opens for appending."""
        pairs: list[TrainingPair] = []
        if not self.durable:
            return pairs
        self.path.parent.mkdir(parents=True, exist_ok=True)
        good_bytes = 0
        if self.path.exists():
            unpacker = msgpack.Unpacker(raw=False)
            unpacker.feed(self.path.read_bytes())
            try:
                for item in unpacker:  # stops, without a record, where the last one is cut short
                    pairs.append(self._pair(item, len(pairs) + 1))
                    good_bytes = unpacker.tell()
            except (ValueError, msgpack.UnpackException) as err:  # bytes that are no msgpack at all
                raise PairLogError(f"{self.path}: not a pair log after record {len(pairs)} ({err}); "
                                   "the file is kept as it is: move it away to start afresh") from None
            if good_bytes < self.path.stat().st_size:
                os.truncate(self.path, good_bytes)  # drop the torn tail, keep every whole pair
        self._file, self._n = open(self.path, "ab"), len(pairs)
        return pairs

    def _pair(self, item, number: int) -> TrainingPair:
        try:
            return decode(TrainingPair, msgpack.packb(item, use_bin_type=True), str(self.path),
                          {"x": self.n_in, "y": self.n_out})
        except (ValueError, SchemaError) as err:
            raise PairLogError(f"{self.path}: record {number} is not a {self.n_in} -> {self.n_out} training pair "
                               f"({err}); the file is kept as it is: start the learner with the spaces it was "
                               "written with, or move the file away to start afresh") from None

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
        if self._scratch is not None:
            self._scratch.cleanup()
            self._scratch = None
