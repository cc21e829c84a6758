"""A fake Zenoh session for unit tests of boxes: what a box publishes is a list of (key, payload); what
it receives (samples, liveliness, queries) is handed to the callbacks it declared, as Zenoh would. A box's
runtime (services/bus/runtime.py) runs on it as on the real bus: `fake_box`. Integration tests use the
real bus."""
from __future__ import annotations

import logging
import types

import zenoh

from bus_schema import InstanceKeys
from services.bus.runtime import BoxRuntime


class FakePublisher:
    def __init__(self, bus: FakeSession, key: str):
        self.bus, self.key = bus, key
        self.matching_status = types.SimpleNamespace(matching=True)

    def put(self, payload: bytes) -> None:
        self.bus.published.append((self.key, bytes(payload)))
        if self.key in self.bus.responders:
            self.bus.responders[self.key](bytes(payload))


class FakeDeclaration:
    """A subscriber or a liveliness token: listed on the bus until undeclared."""

    def __init__(self, listing: list, key: str, callback=None):
        self.listing, self.key, self.callback = listing, key, callback
        listing.append(self)

    def undeclare(self) -> None:
        self.listing.remove(self)


class FakeQuery:
    """A query as a queryable's callback gets it; what it was answered is kept."""

    def __init__(self, key: str, parameters: str = ""):
        self.key_expr, self.parameters = key, zenoh.Parameters(parameters)
        self.replies: list[tuple[str, bytes]] = []
        self.errors: list[bytes] = []

    def reply(self, key: str, payload: bytes) -> None:
        self.replies.append((str(key), bytes(payload)))

    def reply_err(self, payload: bytes) -> None:
        self.errors.append(bytes(payload))


class FakeReply:
    def __init__(self, payload: bytes):
        self.ok, self.err = types.SimpleNamespace(payload=types.SimpleNamespace(to_bytes=lambda: payload)), None


class FakeSession:
    def __init__(self):
        self.published: list[tuple[str, bytes]] = []
        self.answerers: dict[str, object] = {}  # key -> answer(parameters) -> payload or None
        self.responders: dict[str, object] = {}  # key -> respond(payload): another box hearing what is put
        self.asked: list[str] = []
        self.subscribers: list[FakeDeclaration] = []
        self.alive_subscribers: list[FakeDeclaration] = []
        self.queryables: list[FakeDeclaration] = []
        self.tokens: list[FakeDeclaration] = []
        self.alive_elsewhere: set[str] = set()  # liveliness tokens other processes hold (deliver_alive)

    def answer(self, key: str, answerer) -> None:
        """Someone answers queries on `key`: answerer(zenoh.Parameters) -> payload bytes, or None (no reply)."""
        self.answerers[key] = answerer

    def respond(self, key: str, responder) -> None:
        """Someone hears what is put on `key` at once: responder(payload), which may deliver an answer."""
        self.responders[key] = responder

    def get(self, selector: str, **_options):
        self.asked.append(selector)
        key, _, query = selector.partition("?")
        answerer = self.answerers.get(key)
        payload = answerer(zenoh.Parameters(query)) if answerer else None
        return [] if payload is None else [FakeReply(payload)]

    def declare_publisher(self, key: str, **_qos) -> FakePublisher:
        return FakePublisher(self, str(key))

    def declare_subscriber(self, key: str, callback) -> FakeDeclaration:
        return FakeDeclaration(self.subscribers, str(key), callback)

    def declare_queryable(self, key: str, callback) -> FakeDeclaration:
        return FakeDeclaration(self.queryables, str(key), callback)

    def liveliness(self):
        def declare_subscriber(key, callback, history=False):
            subscriber = FakeDeclaration(self.alive_subscribers, str(key), callback)
            for token in list(self.alive_elsewhere) if history else ():  # those already declared, first
                _hand([subscriber], token, b"", zenoh.SampleKind.PUT)
            return subscriber
        return types.SimpleNamespace(declare_token=lambda key: FakeDeclaration(self.tokens, str(key)),
                                     declare_subscriber=declare_subscriber)

    def deliver(self, key: str, payload: bytes) -> int:
        """`payload` put on `key`: handed to every subscriber whose key expression matches; returns how many."""
        return _hand(self.subscribers, key, payload, zenoh.SampleKind.PUT)

    def deliver_alive(self, key: str, alive: bool = True) -> int:
        """A liveliness token on `key` declared (or undeclared) elsewhere: to every liveliness subscriber
        matching it, and to those declared later with history while it stays."""
        (self.alive_elsewhere.add if alive else self.alive_elsewhere.discard)(key)
        return _hand(self.alive_subscribers, key, b"", zenoh.SampleKind.PUT if alive else zenoh.SampleKind.DELETE)

    def query(self, key: str, parameters: str = "") -> FakeQuery:
        """A query on `key` handed to the queryable declared on it; the test reads its replies."""
        query = FakeQuery(key, parameters)
        [queryable] = [q for q in self.queryables if zenoh.KeyExpr(q.key).intersects(key)]
        queryable.callback(query)
        return query

    def on(self, key: str) -> list[bytes]:
        """The payloads published on `key`, in order."""
        return [payload for k, payload in self.published if k == key]


def _hand(declarations: list[FakeDeclaration], key: str, payload: bytes, kind) -> int:
    sample = types.SimpleNamespace(key_expr=key, payload=types.SimpleNamespace(to_bytes=lambda: payload), kind=kind)
    matched = [d for d in declarations if zenoh.KeyExpr(d.key).intersects(key)]
    for declaration in matched:
        declaration.callback(sample)
    return len(matched)


class FakeStop:
    """A box's stop flag that a test sets, or that sets itself once asked `after` times (a box's loop asks
    once per batch; fetch_spaces once per attempt)."""

    def __init__(self, after: int | None = None):
        self.left, self.stopped = after, False

    def __bool__(self) -> bool:
        if self.left is not None and not self.stopped:
            self.stopped, self.left = self.left <= 0, self.left - 1
        return self.stopped

    def set(self) -> None:
        self.stopped = True


def fake_box(role: str = "test", name: str = "test", instance: str = "main", bus: FakeSession | None = None,
             turns: int | None = None) -> BoxRuntime:
    """A box's runtime, open, on a fake bus (`box.session`); its loop ends after `turns` batches if given."""
    return BoxRuntime(bus or FakeSession(), InstanceKeys(instance), role, name, stop=FakeStop(turns),
                      log=logging.getLogger(f"test.{role}.{name}")).open()
