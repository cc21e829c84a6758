"""Learner snapshots as data only: msgpack of plain values, numpy arrays and the learners' own state
classes, named from a fixed registry. A snapshot may come from the bus (hot-swap warming), so reading
one builds arrays and known classes and nothing else: no pickle, no import, no code named by the bytes.

    blob = dump(model)              # bytes
    model = load(blob, GP)          # a GP, or SnapshotError saying what is wrong

Layout: a map {"format": FORMAT, "version": VERSION, "state": tree}, where the tree holds None,
bools, ints, floats, strings, lists, maps with string keys, and two extension types: an array
(dtype, shape, raw bytes; a few plain dtypes) and an object (registered class name, its state map).
"""
from __future__ import annotations

import math
from functools import partial

import msgpack
import numpy as np

from bus_schema.codec import MAX_VECTOR

FORMAT, VERSION = "dogged-learner-snapshot", 1
ARRAY, OBJECT = 1, 2  # msgpack extension type codes
DTYPES = frozenset(("<f8", "<f4", "<i8", "<i4", "|b1", "|u1"))
MAX_DIMS = 4
MAX_DEPTH = 32  # of nesting: a learner of learners (per-output) is 6 deep


class SnapshotError(ValueError):
    """Bytes that are not a learner snapshot this version may load."""


_ALLOWED: dict[str, type] = {}  # filled by services.learners when it registers its learners


def allow(*classes: type) -> None:
    """Classes any snapshot may name: services.learners registers its learners and their state classes."""
    _ALLOWED.update({cls.__name__: cls for cls in classes})


def state_classes(learner: type | None = None) -> dict[str, type]:
    """Every class a snapshot may name: those allowed (the registered learners and the state classes they
    keep), and the learner class at hand with the state classes it declares (`Learner.state_classes`: a
    plug-in learner with a state class of its own names it there)."""
    classes = dict(_ALLOWED)
    if learner is not None:
        classes.update({cls.__name__: cls for cls in (learner, *learner.state_classes)})
    return classes


# --- writing ------------------------------------------------------------------------------------
def dump(model) -> bytes:
    known = state_classes(type(model))
    return msgpack.packb({"format": FORMAT, "version": VERSION, "state": _object(model, known)},
                         default=partial(encode_value, known=known), use_bin_type=True, strict_types=True)


def _object(value, known: dict) -> msgpack.ExtType:
    name = type(value).__name__
    if known.get(name) is not type(value):
        raise TypeError(f"a snapshot cannot hold a {type(value).__module__}.{name}: not a registered state class")
    state = value.__getstate__() if hasattr(value, "__getstate__") else None
    state = dict(vars(value) if state is None else state)
    return msgpack.ExtType(OBJECT, msgpack.packb([name, state], default=partial(encode_value, known=known),
                                                 use_bin_type=True, strict_types=True))


def encode_value(value, known: dict | None = None):
    """msgpack's hook for what it does not pack itself."""
    if isinstance(value, np.ndarray):
        array = np.ascontiguousarray(value)
        if array.dtype.str not in DTYPES:
            raise TypeError(f"a snapshot cannot hold arrays of dtype {array.dtype}")
        return msgpack.ExtType(ARRAY, msgpack.packb([array.dtype.str, list(array.shape), array.tobytes()],
                                                    use_bin_type=True))
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, tuple):
        return list(value)
    return _object(value, state_classes() if known is None else known)


# --- reading ------------------------------------------------------------------------------------
def load(blob: bytes, expected: type):
    """The learner in `blob`, which must be an `expected` (or a subclass); SnapshotError otherwise."""
    if not isinstance(blob, (bytes, bytearray, memoryview)):
        raise SnapshotError(f"a snapshot is bytes, not {type(blob).__name__}")
    try:
        top = _unpack(bytes(blob), 0, state_classes(expected))
    except SnapshotError:
        raise
    except Exception as err:  # noqa: BLE001 - any malformed byte string is a refused snapshot
        raise SnapshotError(f"not a learner snapshot: {type(err).__name__}: {err}") from None
    if not isinstance(top, dict) or top.get("format") != FORMAT:
        raise SnapshotError(f"not a learner snapshot (no {FORMAT!r} header)")
    if top.get("version") != VERSION:
        raise SnapshotError(f"snapshot format version {top.get('version')!r}; this version reads {VERSION}")
    model = top.get("state")
    if not isinstance(model, expected):
        raise SnapshotError(f"snapshot holds a {type(model).__name__}, not a {expected.__name__}")
    return model


def _unpack(data: bytes, depth: int, known: dict):
    if depth > MAX_DEPTH:
        raise SnapshotError(f"snapshot nested deeper than {MAX_DEPTH}")
    return msgpack.unpackb(data, raw=False, strict_map_key=True, use_list=True,
                           ext_hook=lambda code, payload: _decode(code, payload, depth + 1, known))


def _decode(code: int, payload: bytes, depth: int, known: dict):
    if code == ARRAY:
        return _array(_unpack(payload, depth, known))
    if code == OBJECT:
        return _build(_unpack(payload, depth, known), known)
    raise SnapshotError(f"unknown extension type {code} in a snapshot")


def _array(fields) -> np.ndarray:
    if not (isinstance(fields, list) and len(fields) == 3):
        raise SnapshotError("an array is [dtype, shape, bytes]")
    dtype, shape, raw = fields
    if dtype not in DTYPES:
        raise SnapshotError(f"array dtype {dtype!r} is not one of {sorted(DTYPES)}")
    if not (isinstance(shape, list) and len(shape) <= MAX_DIMS
            and all(isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in shape)):
        raise SnapshotError(f"array shape {shape!r} is not up to {MAX_DIMS} non-negative integers")
    if not isinstance(raw, bytes) or len(raw) != math.prod(shape) * np.dtype(dtype).itemsize:
        raise SnapshotError(f"array of shape {shape} and dtype {dtype} does not match its {len(raw)} bytes")
    return np.frombuffer(raw, dtype=dtype).reshape(shape).copy()


def _build(fields, known: dict):
    if not (isinstance(fields, list) and len(fields) == 2 and isinstance(fields[1], dict)):
        raise SnapshotError("an object is [class name, state map]")
    name, state = fields
    cls = known.get(name) if isinstance(name, str) else None
    if cls is None:
        raise SnapshotError(f"a snapshot holds arrays and learner state only, not {name!r}")
    if callable(getattr(cls, "predict_one", None)):  # a learner (services.learners.base.Learner)
        for size in ("n_in", "n_out"):  # before a fresh learner of that size is built (Learner.__setstate__)
            n = state.get(size)
            if not (isinstance(n, int) and not isinstance(n, bool) and 1 <= n <= MAX_VECTOR):
                raise SnapshotError(f"a learner's {size} must be an integer in 1..{MAX_VECTOR}, got {n!r}")
    value = cls.__new__(cls)
    if hasattr(cls, "__setstate__"):
        value.__setstate__(state)
    else:
        for key, item in state.items():
            object.__setattr__(value, key, item)  # frozen dataclasses (Hyper) too
    return value


__all__ = ["FORMAT", "SnapshotError", "VERSION", "allow", "dump", "encode_value", "load", "state_classes"]
