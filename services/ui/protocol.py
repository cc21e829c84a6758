"""What the page may say to the UI server, checked before anything reaches the bus.

Every browser message is one JSON text of at most MAX_MESSAGE_BYTES: an object with an "op" and that
op's fields, nothing else. A message that fails is rejected with a reason the page shows; the server
keeps running and nothing is sent on the bus. Numbers must be finite, names as the bus's key names,
vectors as long as the instance's output.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass

from bus_schema.keys import check_name

MAX_MESSAGE_BYTES = 4096
MAX_SEED = 2 ** 31 - 1
MAX_BALL_DISTANCE_M = 10.0  # the arena is a few metres across
OPS = {  # op -> {field: kind}
    "teach": {"teacher": "name_or_empty", "on": "bool", "hold": "bool"},  # hold: let go when the page closes
    "teleop": {"y": "teleop_vector", "sent": "time"},
    "swap": {"service": "name", "spec": "spec"},
    "arena": {"seed": "seed", "balls": "balls"},
    "record": {"on": "bool"},
    "ping": {"sent": "time"},
}
OPTIONAL = {"sent", "hold"}


class BadMessage(ValueError):
    """A browser message the server will not act on; str() is the reason shown on the page."""


@dataclass(frozen=True)
class Message:
    op: str
    fields: dict


def parse(raw: str | bytes, n_outputs: int) -> Message:
    """`raw` checked as a browser message for an instance with `n_outputs` outputs, or BadMessage."""
    if isinstance(raw, bytes):
        raise BadMessage("binary messages are not accepted: send JSON text")
    if len(raw.encode()) > MAX_MESSAGE_BYTES:
        raise BadMessage(f"message of {len(raw.encode())} bytes: at most {MAX_MESSAGE_BYTES}")
    try:
        obj = json.loads(raw, parse_constant=_no_constant)
    except (ValueError, RecursionError) as err:
        raise BadMessage(f"not JSON: {err}") from None
    if not isinstance(obj, dict):
        raise BadMessage(f"expected a JSON object with an 'op', got {type(obj).__name__}")
    op = obj.get("op")
    if op not in OPS:
        raise BadMessage(f"op {op!r} is not one of {', '.join(sorted(OPS))}")
    spec = OPS[op]
    unknown = sorted(set(obj) - set(spec) - {"op"})
    if unknown:
        raise BadMessage(f"{op}: unknown fields {', '.join(unknown)}")
    fields = {}
    for name, kind in spec.items():
        if name not in obj:
            if name in OPTIONAL:
                continue
            raise BadMessage(f"{op}: missing field {name!r}")
        fields[name] = _check(op, name, kind, obj[name], n_outputs)
    return Message(op, fields)


def _no_constant(name: str):
    raise ValueError(f"{name} is not a number JSON allows")


def _check(op: str, name: str, kind: str, value, n_outputs: int):
    where = f"{op}.{name}"
    if kind == "bool":
        if not isinstance(value, bool):
            raise BadMessage(f"{where} must be true or false")
        return value
    if kind in ("name", "name_or_empty"):
        if not isinstance(value, str) or (kind == "name" and not value):
            raise BadMessage(f"{where} must be a name")
        if value:
            try:
                check_name(name, value)
            except ValueError as err:
                raise BadMessage(f"{where}: {err}") from None
        return value
    if kind == "spec":
        if not isinstance(value, str) or not 0 < len(value) <= 200 or not value.isprintable():
            raise BadMessage(f"{where} must be a learner spec of 1 to 200 printable characters")
        return value
    if kind == "time":
        if not _finite(value) or value < 0:
            raise BadMessage(f"{where} must be a non-negative number (milliseconds)")
        return float(value)
    if kind == "seed":
        if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= MAX_SEED:
            raise BadMessage(f"{where} must be an integer from 0 to {MAX_SEED}")
        return value
    if kind == "teleop_vector":
        return _teleop_vector(where, value, n_outputs)
    if kind == "balls":
        return _balls(where, value)
    raise AssertionError(kind)


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _teleop_vector(where: str, value, n_outputs: int) -> list:
    """One entry per output: a number in [-1, 1] (a fraction of the output's range, 1 at its high end)
    or null where the person says nothing (a partial teacher); all null: the person lets go."""
    if not isinstance(value, list) or len(value) != n_outputs:
        raise BadMessage(f"{where} must be a list of {n_outputs} entries (number in [-1, 1] or null)")
    for i, v in enumerate(value):
        if v is not None and not (_finite(v) and -1.0 <= v <= 1.0):
            raise BadMessage(f"{where}[{i}] must be a number in [-1, 1] or null, got {v!r}")
    return [None if v is None else float(v) for v in value]


def _balls(where: str, value) -> dict:
    if not isinstance(value, dict) or len(value) > 8:
        raise BadMessage(f"{where} must be an object of at most 8 balls: name -> [x, y] or null")
    balls = {}
    for name, xy in value.items():
        try:
            check_name("ball", name)
        except ValueError as err:
            raise BadMessage(f"{where}: {err}") from None
        if xy is not None and not (isinstance(xy, list) and len(xy) == 2 and all(map(_finite, xy))
                                   and all(abs(v) <= MAX_BALL_DISTANCE_M for v in xy)):
            raise BadMessage(f"{where}.{name} must be [x, y] in metres (within {MAX_BALL_DISTANCE_M:g} m) or null")
        balls[name] = None if xy is None else [float(v) for v in xy]
    return balls
