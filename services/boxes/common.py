"""Who is alive in an instance, from its liveliness tokens (the arbitrator's members)."""
from __future__ import annotations

import zenoh

from bus_schema import InstanceKeys


class Membership:
    """Who is alive in this instance, from liveliness tokens (dl/<i>/alive/<role>/<name>)."""

    def __init__(self, keys: InstanceKeys):
        self.keys = keys
        self.alive: dict[str, set[str]] = {}
        self.order: list[str] = []  # members in order of appearance

    def update(self, key: str, kind) -> tuple[str, str] | None:
        parsed = self.keys.parse_alive(key)
        if parsed is None:
            return None
        role, name = parsed
        member = f"{role}/{name}"
        if kind == zenoh.SampleKind.PUT:
            self.alive.setdefault(role, set()).add(name)
            if member not in self.order:
                self.order.append(member)
        else:
            self.alive.get(role, set()).discard(name)
            if member in self.order:
                self.order.remove(member)
        return parsed

    def names(self, role: str) -> set[str]:
        return self.alive.get(role, set())
