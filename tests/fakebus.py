"""A fake Zenoh session for unit tests of boxes: what a box publishes is a list of (key, payload); what
it receives is handed to its Inbox as a callback would. Integration tests use the real bus."""
from __future__ import annotations

import types

import zenoh


class FakePublisher:
    def __init__(self, bus: "FakeSession", key: str):
        self.bus, self.key = bus, key
        self.matching_status = types.SimpleNamespace(matching=True)

    def put(self, payload: bytes) -> None:
        self.bus.published.append((self.key, bytes(payload)))


class FakeSession:
    def __init__(self):
        self.published: list[tuple[str, bytes]] = []

    def declare_publisher(self, key: str, **_qos) -> FakePublisher:
        return FakePublisher(self, str(key))

    def on(self, key: str) -> list[bytes]:
        """The payloads published on `key`, in order."""
        return [payload for k, payload in self.published if k == key]


def sample(tag: str, key: str, payload: bytes) -> tuple:
    """An Inbox item as services.bus.Inbox.callback(tag) makes it from a sample put on `key`."""
    return tag, key, payload, zenoh.SampleKind.PUT
