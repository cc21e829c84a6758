"""What a learner is given, checked: inputs and outputs as finite float64 arrays of the right shape (an error that
names the first bad entry), arrays made ready for a compiled kernel, and hyper-parameters as numbers in range (an
error that names the hyper-parameter)."""
from __future__ import annotations

import math

import numpy as np

from .errors import LearnerInputError


def as_vector(values, length: int, what: str) -> np.ndarray:
    """A float64 copy-free view of `values` checked to be `length` finite numbers."""
    array = np.asarray(values, dtype=np.float64)
    if array.shape != (length,):
        got = array.shape[0] if array.ndim == 1 else f"shape {array.shape}"
        raise LearnerInputError(f"expected {length} {what}, got {got}")
    if not np.isfinite(array).all():
        raise LearnerInputError(describe_non_finite(array, what))
    return array


def as_matrix(values, width: int, what: str, rows: int | None = None) -> np.ndarray:
    """A float64 (n, width) array of finite numbers."""
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != width:
        raise LearnerInputError(f"expected rows of {width} {what}, got shape {array.shape}")
    if rows is not None and array.shape[0] != rows:
        raise LearnerInputError(f"expected {rows} rows of {what}, got {array.shape[0]}")
    if not np.isfinite(array).all():
        raise LearnerInputError(describe_non_finite(array, what))
    return array


def kernel_ready(values) -> np.ndarray:
    """C-contiguous, writeable float64 for a numba kernel: read-only arrays (np.frombuffer
    on a bus payload) would make numba compile a second specialisation, a long stall."""
    array = np.ascontiguousarray(values, dtype=np.float64)
    return array if array.flags.writeable else array.copy()


def describe_non_finite(array: np.ndarray, what: str) -> str:
    """'input 3 is nan' (or 'row 5, input 3 is inf') for the first non-finite entry."""
    index = np.argwhere(~np.isfinite(array))[0]
    value = array[tuple(index)]
    singular = what[:-1] if what.endswith("s") else what
    where = f"row {index[0]}, {singular} {index[1]}" if array.ndim == 2 else f"{singular} {index[0]}"
    return f"{where} is {value}; learners need finite numbers, check the upstream sensor or filter"


def check_positive(name: str, value, strictly: bool = True) -> float:
    """The value as a float, or ValueError naming the hyper-parameter."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"hyper-parameter {name} must be a number, got {value!r}") from None
    if not math.isfinite(number) or number < 0 or (strictly and number == 0):
        kind = "positive" if strictly else "non-negative"
        raise ValueError(f"hyper-parameter {name} must be a finite {kind} number, got {value!r}")
    return number


def check_range(name: str, value, low: float, high: float) -> float:
    number = check_positive(name, value, strictly=False) if low >= 0 else float(value)
    if not low <= number <= high:
        raise ValueError(f"hyper-parameter {name} must be in [{low}, {high}], got {value!r}")
    return number
