"""Every training pair a learner has incorporated, in an append-only file; memory holds only their count.

The file is a stream of msgpack TrainingPair payloads; a crash can cut the last record short, so
replay stops where the last record is incomplete and truncates the file there. A whole record that is
not a pair this learner can learn (other dimensions: the spaces changed, or were answered by someone
else) is a PairLogError, and the file is left as it is: nothing a learner was taught is thrown away.
History (what a replacement learns at a hot-swap) is read from a second, temporary file of raw float64 rows (x
| y | mask | who taught it, numbered by bus_schema.teachers), in one read: decoding every record instead took
a second per 100,000 pairs, a second the old learner, still serving ticks, would not answer. A learner with no
state directory keeps only that temporary file, which goes when it does. Hours of teaching cost disk, not
memory.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import msgpack
import numpy as np

from bus_schema import SchemaError, TrainingPair, decode, encode
from bus_schema.teachers import TeacherColumn


class PairLogError(RuntimeError):
    """A pair log this learner cannot replay; the file is untouched."""


class PairLog:
    def __init__(self, n_in: int, n_out: int, path: str | os.PathLike | None = None):
        self.n_in, self.n_out = n_in, n_out
        self.path = Path(path) if path else None  # the durable log (msgpack TrainingPairs), flushed per pair
        self._scratch = tempfile.TemporaryDirectory(prefix="dogged-pairs-")
        self.rows_path = Path(self._scratch.name) / "rows"
        self._rows = open(self.rows_path, "ab")
        self._file = None  # the durable log, open once replay_file has read it
        self.teachers = TeacherColumn()  # the rows' teachers, by number
        self._n = 0

    def __len__(self) -> int:
        return self._n

    def append(self, pair: TrainingPair) -> None:
        if self.path is not None:
            if self._file is None:
                raise RuntimeError(f"{self.path}: replay_file() first (it reads what an earlier run left)")
            self._file.write(encode(pair))
            self._file.flush()  # a crash loses at most a torn record
        self._write_row(pair)
        self._n += 1

    def _write_row(self, pair: TrainingPair) -> None:
        mask = np.ones(self.n_out) if pair.mask is None else pair.mask
        teacher = float(self.teachers.number(pair.source))
        self._rows.write(np.concatenate([pair.x, pair.y, mask, [teacher]]).astype(np.float64).tobytes())

    def history(self, n: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, str, bytes]:
        """The first n pairs (all by default) as PairBatch's fields after its epoch and first seq: (x, y, mask)
        arrays and who taught each (teachers, teacher_of), in one read of the rows file."""
        n = self._n if n is None else min(n, self._n)
        self._rows.flush()
        n_in, n_out = self.n_in, self.n_out
        width = n_in + 2 * n_out + 1
        rows = np.fromfile(self.rows_path, dtype=np.float64, count=n * width).reshape(n, width)
        return (rows[:, :n_in], rows[:, n_in:n_in + n_out], rows[:, n_in + n_out:-1],
                *self.teachers.encoded(rows[:, -1]))

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
        for pair in pairs:
            self._write_row(pair)
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
        for f in (self._file, self._rows):
            if f is not None:
                f.close()
        self._file = self._rows = None
        if self._scratch is not None:
            self._scratch.cleanup()
            self._scratch = None
