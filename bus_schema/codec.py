"""msgpack maps with a schema version; vectors travel as packed little-endian float64 bytes.

Every message class lists FIELDS as (name, kind) pairs; a field added later names its default in
DEFAULTS, so a message from an older sender (without it) still decodes. `decode` checks the version, every
field's presence and type, vector lengths and finiteness, and the payload's size, and raises a
SchemaError naming the key and the field.
"""
from __future__ import annotations

import math
from typing import Any, TypeVar

import msgpack
import numpy as np

from .errors import SchemaError

VERSION = 1
MAX_VECTOR = 4096          # floats in one vector
MAX_PAYLOAD = 256 * 1024   # bytes in one message, unless a class says otherwise

INT, FLOAT, STR, BOOL, VECTOR, OPT_VECTOR, BYTES, MAP, VECTORS = (
    "int", "float", "str", "bool", "vector", "vector|nil", "bytes", "map", "vectors")

T = TypeVar("T")


def pack_vector(values) -> bytes:
    return np.ascontiguousarray(values, dtype="<f8").tobytes()


def unpack_vector(raw: Any, key: str, field: str, dims: int | None = None, rows: bool = False) -> np.ndarray:
    if not isinstance(raw, (bytes, bytearray)):
        raise SchemaError(key, field, f"expected packed float64 bytes, got {type(raw).__name__}")
    if len(raw) % 8:
        raise SchemaError(key, field, f"byte length {len(raw)} is not a multiple of 8 (float64)")
    v = np.frombuffer(raw, dtype="<f8")
    limit = MAX_VECTOR * (1 << 16 if rows else 1)
    if v.size > limit:
        raise SchemaError(key, field, f"{v.size} values exceed the limit of {limit}")
    if rows:
        if dims is None or dims <= 0 or v.size % dims:
            raise SchemaError(key, field, f"{v.size} values do not form rows of {dims}")
        v = v.reshape(-1, dims)
    elif dims is not None and v.size != dims:
        raise SchemaError(key, field, f"expected {dims} values, got {v.size}")
    if not np.isfinite(v).all():
        bad = int(np.flatnonzero(~np.isfinite(v.ravel()))[0])
        raise SchemaError(key, field, f"value {bad} is {v.ravel()[bad]} (NaN and inf are rejected)")
    return v


def encode(msg) -> bytes:
    out: dict[str, Any] = {"v": VERSION}
    for name, kind in type(msg).FIELDS:
        value = getattr(msg, name)
        if kind in (VECTOR, VECTORS) or (kind == OPT_VECTOR and value is not None):
            value = pack_vector(value)
        out[name] = value
    return msgpack.packb(out, use_bin_type=True)


def _check_scalar(key: str, name: str, kind: str, value: Any) -> Any:
    if kind == INT and (isinstance(value, bool) or not isinstance(value, int)):
        raise SchemaError(key, name, f"expected an integer, got {type(value).__name__}")
    if kind == FLOAT:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SchemaError(key, name, f"expected a number, got {type(value).__name__}")
        if not math.isfinite(value):
            raise SchemaError(key, name, f"{value} is not finite")
        return float(value)
    if kind == STR and not isinstance(value, str):
        raise SchemaError(key, name, f"expected a string, got {type(value).__name__}")
    if kind == BOOL and not isinstance(value, bool):
        raise SchemaError(key, name, f"expected true or false, got {type(value).__name__}")
    if kind == BYTES and not isinstance(value, (bytes, bytearray)):
        raise SchemaError(key, name, f"expected bytes, got {type(value).__name__}")
    if kind == MAP and not isinstance(value, dict):
        raise SchemaError(key, name, f"expected a map, got {type(value).__name__}")
    return value


def decode(cls: type[T], raw: bytes, key: str, dims: dict[str, int] | None = None) -> T:
    """Decode and validate `raw` as `cls`; `dims` gives the expected length of vector fields."""
    limit = getattr(cls, "MAX_BYTES", MAX_PAYLOAD)
    if len(raw) > limit:
        raise SchemaError(key, "*", f"payload of {len(raw)} bytes exceeds the limit of {limit}")
    try:
        data = msgpack.unpackb(raw, raw=False, strict_map_key=True)
    except Exception as exc:  # msgpack raises several types for garbage
        raise SchemaError(key, "*", f"not a msgpack payload ({type(exc).__name__})") from None
    if not isinstance(data, dict):
        raise SchemaError(key, "*", f"expected a msgpack map, got {type(data).__name__}")
    if data.get("v") != VERSION:
        raise SchemaError(key, "v", f"unknown schema version {data.get('v')!r}; this side speaks {VERSION}")
    dims = dims or {}
    values = {}
    for name, kind in cls.FIELDS:
        if name not in data:
            if name in getattr(cls, "DEFAULTS", {}):
                values[name] = cls.DEFAULTS[name]
                continue
            raise SchemaError(key, name, "missing")
        value = data[name]
        if kind in (VECTOR, VECTORS) or (kind == OPT_VECTOR and value is not None):
            # an optional vector (e.g. a mask) has the length of the vector it qualifies
            expected = dims.get(name, dims.get("y") if kind == OPT_VECTOR or name == "mask" else None)
            value = unpack_vector(value, key, name, expected, rows=kind == VECTORS)
        else:
            value = _check_scalar(key, name, kind, value)
        values[name] = value
    msg = cls(**values)
    check = getattr(msg, "check", None)
    if check is not None:
        check(key)
    return msg



def decoded(cls: type[T], key: str, raw: bytes) -> T | None:
    """decode(), or None for bytes that do not decode as `cls` (anyone may have put anything on a key)."""
    try:
        return decode(cls, raw, key)
    except ValueError:  # SchemaError is one
        return None
