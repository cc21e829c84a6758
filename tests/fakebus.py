"""A fake Zenoh session for unit tests of boxes: what a box publishes is a list of (key, payload); what
it receives is handed to its Inbox as a callback would. Integration tests use the real bus."""
from __future__ import annotations

import types

import zenoh


class FakePublisher:
    def __init__(self, bus: FakeSession, key: str):
        self.bus, self.key = bus, key
        self.matching_status = types.SimpleNamespace(matching=True)

    def put(self, payload: bytes) -> None:
        self.bus.published.append((self.key, bytes(payload)))


class FakeDeclaration:
    """A subscriber or a liveliness token: listed on the bus until undeclared."""

    def __init__(self, listing: list, key: str, callback=None):
        self.listing, self.key, self.callback = listing, key, callback
        listing.append(self)

    def undeclare(self) -> None:
        self.listing.remove(self)


class FakeReply:
    def __init__(self, payload: bytes):
        self.ok, self.err = types.SimpleNamespace(payload=types.SimpleNamespace(to_bytes=lambda: payload)), None


class FakeSession:
    def __init__(self):
        self.published: list[tuple[str, bytes]] = []
        self.answerers: dict[str, object] = {}  # key -> answer(parameters) -> payload or None
        self.asked: list[str] = []
        self.subscribers: list[FakeDeclaration] = []
        self.tokens: list[FakeDeclaration] = []

    def answer(self, key: str, answerer) -> None:
        """Someone answers queries on `key`: answerer(zenoh.Parameters) -> payload bytes, or None (no reply)."""
        self.answerers[key] = answerer

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

    def liveliness(self):
        return types.SimpleNamespace(declare_token=lambda key: FakeDeclaration(self.tokens, str(key)))

    def deliver(self, key: str, payload: bytes) -> int:
        """`payload` put on `key`: handed to every subscriber of exactly that key; returns how many."""
        sample = types.SimpleNamespace(key_expr=key, payload=types.SimpleNamespace(to_bytes=lambda: payload),
                                       kind=zenoh.SampleKind.PUT)
        matched = [s for s in self.subscribers if s.key == key]
        for subscriber in matched:
            subscriber.callback(sample)
        return len(matched)

    def on(self, key: str) -> list[bytes]:
        """The payloads published on `key`, in order."""
        return [payload for k, payload in self.published if k == key]
