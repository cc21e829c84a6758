"""What a service hears. Callbacks run on Zenoh's threads: they only append (tag, key, bytes) to an
inbox; the service's own thread decodes, validates and acts, so nothing blocks or calls Zenoh inside a
callback. A payload that does not decode is rejected: counted by key and logged with its reason.

An inbox holds at most `max_bytes` of what is waiting: a sender faster than the service (a flood, a
stalled disk under the recorder) would otherwise grow its memory until the kernel kills it, losing
everything. Past the budget a message is dropped on arrival, counted (`dropped`, in the service's status
as `inbox_dropped`) and logged by the service's thread with the reason.

The queue is a deque under a Condition, not queue.SimpleQueue: CPython 3.11's SimpleQueue.get(timeout)
waits forever (until the next put) when a signal interrupts it after its deadline, so a SIGTERM could
leave a quiet service stuck until the supervisor killed it (and a recorder's file unfinished).
threading's lock re-checks its deadline after a signal (tests/test_inbox.py gets under a storm of signals)."""
from __future__ import annotations

import logging
import threading
import time
from collections import Counter, deque

import zenoh

from bus_schema import SchemaError, decode

DEFAULT_MAX_BYTES = 64 * 2**20  # 32 of the largest camera frames the schema allows; some 300k small messages
ITEM_OVERHEAD = 256  # bytes a queued item costs beyond its payload (tuple, key string, bytes object)
QUERY_BYTES = 4096  # a query's share: its parameters and payload stay in Zenoh's object


class Inbox:
    """A bounded queue the Zenoh callbacks feed; the service thread drains it."""

    def __init__(self, max_bytes: int = DEFAULT_MAX_BYTES):
        if max_bytes < 1:
            raise ValueError(f"an inbox needs a positive byte budget, got {max_bytes!r}")
        self.max_bytes = max_bytes
        self.dropped = 0  # messages refused on arrival because the budget was spent
        self._items: deque = deque()  # (item, size)
        self._lock = threading.Lock()  # held for an addition or a removal: a callback never waits on the service
        self._arrived = threading.Condition(self._lock)
        self._held = 0  # bytes waiting
        self._log = logging.getLogger("dogged.inbox")  # (the service's log format names the service)
        self._reported, self._reported_at = 0, 0.0

    def callback(self, tag: str):
        _not_on_a_daemon_thread()
        offer = self._offer

        def on_sample(sample: zenoh.Sample) -> None:
            raw = sample.payload.to_bytes()
            offer((tag, str(sample.key_expr), raw, sample.kind), len(raw))
        return on_sample

    def stamped_callback(self, tag: str):
        """As `callback`, with the arrival time (time.time_ns()) where the sample's kind goes: the
        recorder's log time, taken on arrival, not when its thread gets to the sample."""
        _not_on_a_daemon_thread()
        offer, now_ns = self._offer, time.time_ns

        def on_sample(sample: zenoh.Sample) -> None:
            raw = sample.payload.to_bytes()
            offer((tag, str(sample.key_expr), raw, now_ns()), len(raw))
        return on_sample

    def query_callback(self, tag: str):
        """Queries are answered by the service thread, so the callback only hands them over."""
        _not_on_a_daemon_thread()
        offer = self._offer

        def on_query(query: zenoh.Query) -> None:
            offer((tag, str(query.key_expr), query, None), QUERY_BYTES)
        return on_query

    def put(self, item: tuple) -> None:
        """Hands an item over as a callback does (the recorder's own callback; a test driving a box with no bus)."""
        payload = item[2] if len(item) > 2 else b""
        self._offer(item, len(payload) if isinstance(payload, (bytes, bytearray)) else QUERY_BYTES)

    def _offer(self, item: tuple, size: int) -> None:
        size += ITEM_OVERHEAD
        with self._arrived:
            if self._held + size > self.max_bytes:
                self.dropped += 1
                return
            self._held += size
            self._items.append((item, size))
            self._arrived.notify()

    @property
    def held_bytes(self) -> int:
        return self._held

    @property
    def waiting(self) -> int:
        """Items queued now (a service that stops takes these, not a flood that goes on)."""
        return len(self._items)

    def drain(self, timeout):
        """What came in: waits up to `timeout` for a first item, then yields every item already queued.
        `timeout` may be a function, asked as the first item is waited for (a box's wait until its deadline)."""
        item = self.get(timeout() if callable(timeout) else timeout)
        while item is not None:
            yield item
            item = self.get_nowait()

    def get(self, timeout: float):
        """The oldest item, waiting up to `timeout` seconds for one; None if none came."""
        with self._arrived:
            if not self._items and timeout > 0:
                self._arrived.wait(timeout)  # (a signal during the wait cannot stretch it: see above)
            if not self._items:
                return None
            item, size = self._items.popleft()
            self._held -= size
        if self.dropped > self._reported:
            self._report()
        return item

    def get_nowait(self):
        return self.get(0.0)

    def _report(self) -> None:
        """Logs new drops from the service's thread, at most once a second."""
        if time.monotonic() - self._reported_at >= 1.0:
            self._log.warning("inbox full (%.1f MiB waiting): %d messages dropped on arrival so far; "
                              "something sends faster than this service takes them", self.max_bytes / 2**20,
                              self.dropped)
            self._reported, self._reported_at = self.dropped, time.monotonic()


def _not_on_a_daemon_thread() -> None:
    """A callback is made as it is declared. zenoh-python runs each Python callback on a thread of its
    own that inherits the declaring thread's daemon flag: declared from a daemon thread, those threads
    are not waited for at exit and wake into a finalizing interpreter as the session closes, which
    aborts the process ('FATAL: exception not rethrown': `dogged ui`, in CI). So: declare on the main
    thread, or another that exit waits for."""
    if threading.current_thread().daemon:
        raise RuntimeError("a bus callback must be declared on a thread exit waits for, not a daemon thread")


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
