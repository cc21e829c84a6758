"""What a service hears. Callbacks run on Zenoh's threads: they only append (tag, key, bytes) to an
inbox; the service's own thread decodes, validates and acts, so nothing blocks or calls Zenoh inside a
callback. A payload that does not decode is rejected: counted by key and logged with its reason."""
from __future__ import annotations

import logging
import queue
import time
from collections import Counter

import zenoh

from bus_schema import SchemaError, decode


class Inbox:
    """A queue the Zenoh callbacks feed; the service thread drains it."""

    def __init__(self):
        self._queue: queue.SimpleQueue = queue.SimpleQueue()

    def callback(self, tag: str):
        q = self._queue

        def on_sample(sample: zenoh.Sample) -> None:
            q.put((tag, str(sample.key_expr), sample.payload.to_bytes(), sample.kind))
        return on_sample

    def query_callback(self, tag: str):
        """Queries are answered by the service thread, so the callback only hands them over."""
        q = self._queue

        def on_query(query: zenoh.Query) -> None:
            q.put((tag, str(query.key_expr), query, None))
        return on_query

    def put(self, item: tuple) -> None:
        """Hands an item over as a callback would (a test drives a box with no bus this way)."""
        self._queue.put(item)

    def drain(self, timeout: float):
        """What came in: waits up to `timeout` for a first item, then yields every item already queued."""
        item = self.get(timeout)
        while item is not None:
            yield item
            item = self.get_nowait()

    def get(self, timeout: float):
        try:
            return self._queue.get(timeout=timeout)
        except queue.Empty:
            return None

    def get_nowait(self):
        try:
            return self._queue.get_nowait()
        except queue.Empty:
            return None


class Rejects:
    """Counts rejected payloads by key and logs the reason (at most once a second per key)."""

    def __init__(self, log: logging.Logger):
        self.log, self.counts, self._last_log = log, Counter(), {}

    def __call__(self, key: str, error: Exception) -> None:
        self.counts[key] += 1
        now = time.monotonic()
        if now - self._last_log.get(key, 0.0) >= 1.0:
            self._last_log[key] = now
            self.log.warning("rejected payload (%d so far on this key): %s", self.counts[key], error)

    @property
    def total(self) -> int:
        return sum(self.counts.values())


def decode_or_reject(cls, raw: bytes, key: str, rejects: Rejects, dims: dict | None = None):
    """`raw` decoded as a `cls` message (checked against `dims`), or None, rejected with its reason."""
    try:
        return decode(cls, raw, key, dims)
    except SchemaError as err:
        rejects(key, err)
        return None
