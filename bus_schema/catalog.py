"""Which payload each published key carries, and its channel: README.md's tables as data, for tools that
take the whole bus (the recorder, replay, dashboards). Queries and liveliness tokens carry no sample."""
from __future__ import annotations

from .codec import BOOL, BYTES, FLOAT, INT, MAP, OPT_VECTOR, STR, VECTOR, VECTORS, VERSION
from .messages import (Applied, ArenaReset, Clock, Command, Episode, Frame, Handle, Input, Proposal, RecordSwitch,
                       Reward, RobotState, SelectLearner, Status, TeachSwitch, TrainingPair)

LOSSLESS, LATEST_ONLY = "lossless", "latest-only"

# the part of a key after dl/<instance>/ or robot/<robot>/ -> (payload class, channel)
INSTANCE_PAYLOADS = {
    "input": (Input, LATEST_ONLY), "command": (Command, LATEST_ONLY), "applied": (Applied, LATEST_ONLY),
    "train": (TrainingPair, LOSSLESS), "teach": (TeachSwitch, LOSSLESS),
    "record": (RecordSwitch, LOSSLESS),
    "reward": (Reward, LATEST_ONLY), "episode": (Episode, LOSSLESS),
    "arbitrator/select": (SelectLearner, LOSSLESS),
    "proposal/*/*": (Proposal, LATEST_ONLY), "status/*/*": (Status, LATEST_ONLY),
}
ROBOT_PAYLOADS = {
    "camera": (Frame, LATEST_ONLY), "clock": (Clock, LATEST_ONLY), "state": (RobotState, LATEST_ONLY),
    "handle": (Handle, LATEST_ONLY), "arena": (ArenaReset, LOSSLESS),
}


def payload_of(key: str) -> tuple[type, str] | None:
    """(payload class, channel) of a published key, or None for a key the bus does not publish on."""
    parts = key.split("/")
    if len(parts) < 3 or parts[0] not in ("dl", "robot"):
        return None
    table = INSTANCE_PAYLOADS if parts[0] == "dl" else ROBOT_PAYLOADS
    rest = parts[2:]
    for pattern, found in table.items():
        wanted = pattern.split("/")
        if len(wanted) == len(rest) and all(w == "*" or w == r for w, r in zip(wanted, rest)):
            return found
    return None


_JSON_TYPES = {
    INT: {"type": "integer"}, FLOAT: {"type": "number"}, STR: {"type": "string"}, BOOL: {"type": "boolean"},
    MAP: {"type": "object"},
    BYTES: {"type": "string", "contentEncoding": "binary"},
    VECTOR: {"type": "string", "contentEncoding": "binary",
             "description": "packed little-endian float64 values"},
    OPT_VECTOR: {"type": ["string", "null"], "contentEncoding": "binary",
                 "description": "packed little-endian float64 values, or nil"},
    VECTORS: {"type": "string", "contentEncoding": "binary",
              "description": "rows of packed little-endian float64 values"},
}


def json_schema(cls: type) -> dict:
    """A JSON Schema of a payload class as msgpack carries it (v: the schema version, then FIELDS)."""
    properties = {"v": {"type": "integer", "const": VERSION}}
    properties.update({name: dict(_JSON_TYPES[kind]) for name, kind in cls.FIELDS})
    required = ["v"] + [name for name, _ in cls.FIELDS if name not in getattr(cls, "DEFAULTS", {})]
    return {"title": f"dogged.{cls.__name__}", "description": (cls.__doc__ or "").strip(), "type": "object",
            "properties": properties, "required": required}
