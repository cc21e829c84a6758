"""A box's runtime, in the spirit of dora's `for event in node`: it owns what every box has (one session,
the liveliness token that says the box is up, the stop flag, the bounded inbox its callbacks feed, rejects
and counters, the status once a second) and hands the box its events; a box is its algorithm and one loop:

    with BoxRuntime(conf, InstanceKeys(instance), "default", name) as box:
        box.subscribe(box.keys.input, "input")
        for batch in box.batches(0.1, report):
            for tag, key, payload, kind in batch:
                ...

A batch is what the inbox holds when the box comes to it: the first event waited for up to the wait
given (a number, or a function asked as the body starts on the batch: until a deadline), then every one
already queued, as the inbox yields them (no copy, no thread between callback and box). The wait is the
batch's first step: a body always iterates its batch, and what it does before that (the platform's tick)
it does before the wait. Between batches the status
goes out when due: the box's report, its counters, `rejected` and `inbox_dropped`. The box is announced
alive (its token) as its loop starts, after every declaration and any warming: whoever waits for it (the
arbitrator for a learner) waits for a box that listens.

Subscriptions and queryables are declared on the thread that made the runtime, the main thread (its stop
flag's signal handlers need it): declared from a daemon thread, their callbacks abort the process at exit
(Inbox.callback says why), so the runtime refuses any other thread.
"""
from __future__ import annotations

import collections
import logging
import threading

import zenoh

from services.bus.inbox import DEFAULT_MAX_BYTES, Inbox, Rejects
from services.bus.lifecycle import StopFlag, setup_logging
from services.bus.publishers import StatusPublisher, lossless_publisher, sensor_publisher
from services.bus.queries import fetch_spaces


class BoxRuntime:
    """One box's session, token, stop flag, inbox, rejects, counters and status. `bus` is a zenoh.Config
    (the session is opened on entering and closed on leaving) or a session already open (a test's fake
    bus: left open). `keys` names the status and token (dl/<i>/status|alive/<role>/<name>); `token`, a
    key of another shape, says the box is up instead (the router's; a box with no keys has no status)."""

    def __init__(self, bus, keys, role: str, name: str, *, token: str | None = None,
                 inbox_bytes: int = DEFAULT_MAX_BYTES, stop=None, log: logging.Logger | None = None):
        self.keys, self.role, self.name = keys, role, name
        self.log = log or setup_logging(role, name)
        self.stop = StopFlag() if stop is None else stop
        self.inbox = Inbox(inbox_bytes)
        self.rejects, self.counts = Rejects(self.log), collections.Counter()
        self._conf, self._opened = bus, isinstance(bus, zenoh.Config)
        self.session = None if self._opened else bus
        self.status: StatusPublisher | None = None
        self._token_key = token or keys.alive(role, name)
        self._token = None
        self._held: list = []  # declarations live as long as these references
        self._thread = threading.current_thread()

    # --- lifetime ---------------------------------------------------------------------------------
    def open(self) -> BoxRuntime:
        """Opens the session (a zenoh.ZError if it cannot: the router's port taken) and the status."""
        if self.session is None:
            self.session = zenoh.open(self._conf)
        if self.status is None and self.keys is not None:
            self.status = StatusPublisher(self.session, self.keys.status(self.role, self.name), self.role,
                                          self.name)
        return self

    def __enter__(self) -> BoxRuntime:
        return self.open()

    def __exit__(self, *_exc) -> None:
        for declaration in reversed(self._held):
            declaration.undeclare()
        self._held.clear()
        if self._token is not None:
            self._token.undeclare()
            self._token = None
        if self._opened and self.session is not None:
            self.session.close()

    def announce(self) -> None:
        """The token that says this box is up (the loop's start declares it, if the box has not)."""
        if self._token is None:
            self._token = self.session.liveliness().declare_token(self._token_key)

    # --- what it hears ----------------------------------------------------------------------------
    def subscribe(self, key: str, tag: str, stamped: bool = False):
        """Samples on `key` come as (tag, key, payload, kind); `stamped`: the arrival time.time_ns() for kind."""
        self._on_own_thread(key)
        callback = self.inbox.stamped_callback(tag) if stamped else self.inbox.callback(tag)
        return self._hold(self.session.declare_subscriber(key, callback))

    def subscribe_alive(self, key: str, tag: str):
        """Liveliness tokens on `key`, those already declared first: (tag, key, b"", PUT or DELETE)."""
        self._on_own_thread(key)
        return self._hold(self.session.liveliness().declare_subscriber(key, self.inbox.callback(tag), history=True))

    def queryable(self, key: str, tag: str):
        """Queries on `key` come as (tag, key, query, None); the loop answers them (query.reply)."""
        self._on_own_thread(key)
        return self._hold(self.session.declare_queryable(key, self.inbox.query_callback(tag)))

    def token(self, key: str):
        """Another liveliness token, held until released or the box ends (a teacher's teaching token)."""
        return self._hold(self.session.liveliness().declare_token(key))

    def release(self, declaration) -> None:
        """Undeclares what subscribe, queryable or token gave (a teacher switched off stops listening)."""
        self._held.remove(declaration)
        declaration.undeclare()

    def _hold(self, declaration):
        self._held.append(declaration)
        return declaration

    def _on_own_thread(self, key: str) -> None:
        if threading.current_thread() is not self._thread:
            raise RuntimeError(f"{key}: a box declares its subscriptions and queryables on the thread that made its "
                               f"runtime (the main thread), not on {threading.current_thread().name}: a daemon "
                               "thread's callbacks abort the process at exit")

    # --- what it says and asks ---------------------------------------------------------------------
    def sensor_publisher(self, key: str, bulky: bool = False) -> zenoh.Publisher:
        return sensor_publisher(self.session, key, bulky)

    def lossless_publisher(self, key: str) -> zenoh.Publisher:
        return lossless_publisher(self.session, key)

    def fetch_spaces(self, key: str | None = None, timeout: float | None = None):
        """The platform's spaces (on `key`, default this instance's), asked until it answers; None if stopped."""
        return fetch_spaces(self.session, key or self.keys.spaces, self.stop, self.log, timeout)

    # --- the loop -----------------------------------------------------------------------------------
    def batches(self, wait, report=None):
        """Until stopped: each batch of events that came within `wait` seconds (a number, or a function
        that says how long); the status between batches. report() -> (counters, state) of the box's own."""
        drain, status = self.inbox.drain, self.status

        def full_report() -> tuple[dict, dict]:
            return self.status_report(report)
        self.announce()
        while not self.stop:
            yield drain(wait)
            if status is not None:
                status.maybe_publish(full_report)

    def status_report(self, report=None) -> tuple[dict, dict]:
        """What the status says: the box's counters and its report's, `rejected`, `inbox_dropped`; its state."""
        counters, state = report() if report is not None else ({}, {})
        return {**self.counts, **counters, "rejected": self.rejects.total, "inbox_dropped": self.inbox.dropped}, state
