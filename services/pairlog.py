"""Every training pair a learner has incorporated, in memory and optionally in an append-only file.

The file is a stream of msgpack TrainingPair payloads; a crash can cut the last record short, so
replay stops where the last record is incomplete and truncates the file there. A whole record that is
not a pair this learner can learn (other dimensions: the spaces changed, or were answered by someone
else) is a PairLogError, and the file is left as it is: nothing a learner was taught is thrown away.
"""
from __future__ import annotations

import os
from pathlib import Path

import msgpack
import numpy as np

from bus_schema import SchemaError, TrainingPair, decode, encode


class PairLogError(RuntimeError):
    """A pair log this learner cannot replay; the file is untouched."""


class PairLog:
    def __init__(self, n_in: int, n_out: int, path: str | os.PathLike | None = None):
        self.n_in, self.n_out = n_in, n_out
        self._x = np.empty((1024, n_in))
        self._y = np.empty((1024, n_out))
        self._mask = np.empty((1024, n_out))  # the outputs taught: all 1 for a whole pair
        self._n = 0
        self.path = Path(path) if path else None
        self._file = None

    def __len__(self) -> int:
        return self._n

    def append(self, x: np.ndarray, y: np.ndarray, pair: TrainingPair | None = None, mask=None) -> None:
        if self._n == len(self._x):  # amortised growth: doubling
            self._x = np.concatenate([self._x, np.empty_like(self._x)])
            self._y = np.concatenate([self._y, np.empty_like(self._y)])
            self._mask = np.concatenate([self._mask, np.empty_like(self._mask)])
        self._x[self._n], self._y[self._n] = x, y
        self._mask[self._n] = 1.0 if mask is None else mask
        self._n += 1
        if self._file is not None and pair is not None:
            self._file.write(encode(pair))
            self._file.flush()


    @property
    def x(self) -> np.ndarray:
        return self._x[: self._n]

    @property
    def y(self) -> np.ndarray:
        return self._y[: self._n]

    @property
    def mask(self) -> np.ndarray:
        return self._mask[: self._n]

    def replay_file(self) -> list[TrainingPair]:
        """Pairs saved by an earlier run of this learner (it crashed or was restarted); opens for appending."""
        pairs: list[TrainingPair] = []
        if self.path is None:
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
        self._file = open(self.path, "ab")
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
