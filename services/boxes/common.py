"""What several boxes need from the bus: the platform's spaces and who is alive."""
from __future__ import annotations

import logging
import time

import zenoh

from bus_schema import InstanceKeys, SchemaError, Spaces, SpacesMessage, decode


def fetch_spaces(session: zenoh.Session, keys: InstanceKeys, stop, log: logging.Logger,
                 timeout: float | None = None) -> Spaces | None:
    """Ask the platform for its spaces until it answers (dims come from the platform, not from flags).
    Every answer to one query must agree: spaces that a second answerer contradicts are not trusted
    (without access control anyone may answer; with it only the platform can), and the query is
    asked again."""
    start, warned, wait = time.monotonic(), False, 0.2
    while not stop:
        answers = []
        # every queryable, every answer: two answerers must both be heard to be compared. A session just
        # opened may not hear the end of its first query until the timeout (its links to the other peers
        # are still being made), so the wait starts short and grows (0.2 s, 0.4 s, ... 1.6 s: a radio link)
        for reply in session.get(keys.spaces, timeout=wait, target=zenoh.QueryTarget.ALL,
                                 consolidation=zenoh.ConsolidationMode.NONE):
            if reply.ok is None:
                continue
            try:
                answers.append(Spaces.from_dict(decode(SpacesMessage, reply.ok.payload.to_bytes(), keys.spaces).spaces))
            except (SchemaError, KeyError, TypeError, ValueError) as err:
                log.error("platform spaces rejected: %s", err)
        if answers and all(a.to_dict() == answers[0].to_dict() for a in answers[1:]):
            return answers[0]
        if answers:
            shapes = sorted({f"{a.input.dims} -> {a.output.dims}" for a in answers})
            log.error("%d answers on %s disagree (%s): trusting none, asking again", len(answers), keys.spaces,
                      "; ".join(shapes) if len(shapes) > 1 else "same sizes, other bounds or names")
        if timeout is not None and time.monotonic() - start > timeout:
            return None
        wait = min(2 * wait, 1.6)
        if not warned and time.monotonic() - start > 3:
            log.info("waiting for the platform to answer on %s", keys.spaces)
            warned = True
        time.sleep(0.1)
    return None


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
