"""A taught student as a file, to run again without the bus: in a script, a notebook, a Gymnasium evaluation.

    save_student("pendulum.student", model, spaces, origin="dogged snapshot learner")
    student = load_student("pendulum.student")
    y, confidence = student.act(x)       # as the live learner box answered: clipped to the output space
    action = student.policy(observation)  # Gymnasium-style: an environment's observation in, its action out

The file is data only: a msgpack map holding the spaces, the learner's class name and its snapshot
(services.learners.snapshot_codec: arrays, numbers and registered state classes, never a pickle).
"""
from __future__ import annotations

from pathlib import Path

import msgpack
import numpy as np

from bus_schema.spaces import Spaces

from .registry import LEARNERS
from .snapshot_codec import SnapshotError

FORMAT, VERSION = "dogged-student", 1
MAX_BYTES = 1 << 30  # a student larger than this is no file dogged wrote


class StudentFileError(ValueError):
    """A file that is not a student this version can load, saying why."""


class Student:
    """A learner with the spaces it was taught in; answers as the live learner box did."""

    def __init__(self, model, spaces: Spaces, origin: str = ""):
        if (model.n_in, model.n_out) != (spaces.input.dims, spaces.output.dims):
            raise ValueError(f"a {model.n_in} -> {model.n_out} learner does not fit spaces of "
                             f"{spaces.input.dims} inputs and {spaces.output.dims} outputs")
        self.model, self.spaces, self.origin = model, spaces, origin

    def act(self, x) -> tuple[np.ndarray, float]:
        """(output clipped to the output space, confidence in [0, 1]) for one input."""
        p = self.model.predict_one(x)
        return self.spaces.output.clip(p.y), float(p.confidence)

    def policy(self, observation):
        """A Gymnasium action for an observation, as the gym platform would apply the student's answer:
        the observation flattened and clipped to the input bounds; for a discrete action space (one output
        per action) the index of the largest, else the output as float32."""
        x = self.spaces.input.clip(np.asarray(observation, dtype=np.float64).ravel())
        y, _ = self.act(x)
        if self.spaces.extra.get("choice") == "largest":
            return int(np.argmax(y))
        return y.astype(np.float32)

    @property
    def learner(self) -> str:
        return type(self.model).__name__

    def __repr__(self) -> str:
        names = ", ".join(self.spaces.input.names) or f"{self.spaces.input.dims} inputs"
        return f"Student({self.learner}, {self.model.n_learned} pairs learned; {names} -> {self.spaces.output.dims})"


def save_student(path: str | Path, model, spaces: Spaces, origin: str = "") -> Path:
    """Writes the student file (replacing any file there); returns its path."""
    path = Path(path)
    blob = msgpack.packb({"format": FORMAT, "version": VERSION, "learner": type(model).__name__,
                          "spaces": spaces.to_dict(), "n_learned": int(model.n_learned), "origin": origin,
                          "snapshot": model.snapshot()}, use_bin_type=True)
    tmp = path.with_name(path.name + ".writing")
    tmp.write_bytes(blob)
    tmp.replace(path)
    return path


def load_student(path: str | Path) -> Student:
    """The student in a file written by `dogged export --student` or `dogged snapshot learner`;
    StudentFileError naming what is wrong otherwise."""
    path = Path(path)
    if not path.is_file():
        raise StudentFileError(f"{path}: no such file")
    if path.stat().st_size > MAX_BYTES:
        raise StudentFileError(f"{path}: {path.stat().st_size} bytes, more than any student file")
    try:
        top = msgpack.unpackb(path.read_bytes(), raw=False, strict_map_key=True)
    except Exception as err:  # noqa: BLE001 - any malformed bytes are a refused file
        raise StudentFileError(f"{path}: not a student file ({type(err).__name__})") from None
    if not isinstance(top, dict) or top.get("format") != FORMAT:
        raise StudentFileError(f"{path}: not a student file (no {FORMAT!r} header)")
    if top.get("version") != VERSION:
        raise StudentFileError(f"{path}: student file version {top.get('version')!r}; this version reads {VERSION}")
    classes = {cls.__name__: cls for cls in LEARNERS.values()}
    cls = classes.get(top.get("learner"))
    if cls is None:
        raise StudentFileError(f"{path}: learner {top.get('learner')!r} is not one of {', '.join(sorted(classes))}")
    try:
        spaces = Spaces.from_dict(top["spaces"])
        model = cls.restore(top["snapshot"])
        return Student(model, spaces, str(top.get("origin", "")))
    except (SnapshotError, KeyError, TypeError, ValueError) as err:
        raise StudentFileError(f"{path}: {err}") from None

