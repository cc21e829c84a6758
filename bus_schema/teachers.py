"""Who taught each row of a batch of training pairs (PairBatch): the teachers' names, one a line, and per row
one byte, the line of its teacher. Learners that tell teachers apart (the GP: each teacher's own noise) learn a
hot-swap's history, a gap filled and a restart's log as they learned the pairs live."""
from __future__ import annotations

import numpy as np

from .errors import SchemaError

MOST_TEACHERS = 255  # names in one column; any later teacher is numbered as the last ("others")
OTHERS = "others"
LONGEST_NAME = 130


class TeacherColumn:
    """Teachers numbered in the order first seen, at most MOST_TEACHERS (the last line then stands for the rest)."""

    def __init__(self):
        self.names: list[str] = []
        self._numbers: dict[str, int] = {}

    def number(self, name: str) -> int:
        if name in self._numbers:
            return self._numbers[name]
        if len(self.names) == MOST_TEACHERS - 1:
            self.names.append(OTHERS)
        if len(self.names) >= MOST_TEACHERS:
            return MOST_TEACHERS - 1
        self.names.append(name)
        self._numbers[name] = len(self.names) - 1
        return len(self.names) - 1

    def encoded(self, numbers: np.ndarray) -> tuple[str, bytes]:
        """(teachers, teacher_of) of PairBatch for rows numbered `numbers`."""
        return "\n".join(self.names), np.asarray(numbers, dtype=np.uint8).tobytes()


def check_column(key: str, teachers: str, teacher_of: bytes, rows: int) -> None:
    if not teacher_of:
        return
    names = teachers.split("\n")
    if len(teacher_of) != rows:
        raise SchemaError(key, "teacher_of", f"{len(teacher_of)} teachers for {rows} rows")
    if len(names) > MOST_TEACHERS or any(not 0 < len(name) <= LONGEST_NAME for name in names):
        raise SchemaError(key, "teachers", f"at most {MOST_TEACHERS} names of 1 to {LONGEST_NAME} characters, "
                                           "one a line")
    most = max(teacher_of)
    if most >= len(names):
        raise SchemaError(key, "teacher_of", f"teacher {most} of {len(names)} named")


def sources_of(teachers: str, teacher_of: bytes) -> list[str] | None:
    """Each row's teacher, None where the batch does not say (a sender from before teachers were told)."""
    if not teacher_of:
        return None
    names = teachers.split("\n")
    return [names[i] for i in teacher_of]
