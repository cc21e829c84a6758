"""What a service says: latest-only sensor streams, lossless streams, its status once a second."""
from __future__ import annotations

import os
import socket
import time

import zenoh

from bus_schema import Status, encode
from services.waiting import poll

HOST = os.environ.get("DOGGED_HOST") or socket.gethostname()  # the machine a service's status says it runs on


class StatusPublisher:
    """Publishes a Status once a second (latest-only: a lost one is replaced by the next)."""

    def __init__(self, session: zenoh.Session, key: str, role: str, name: str, period: float = 1.0):
        self._pub = session.declare_publisher(key, congestion_control=zenoh.CongestionControl.DROP,
                                              priority=zenoh.Priority.BACKGROUND)
        self.role, self.name, self.period, self._next = role, name, period, 0.0
        self._previous: tuple[float, dict] | None = None

    def publish_soon(self) -> None:
        """The next maybe_publish publishes, whenever the last one was (a change worth telling at once)."""
        self._next = 0.0

    def maybe_publish(self, report) -> None:
        """When due, publishes report() -> (counters, state), adding state['rates']: each counter's
        change per second since the last status. `report` is only called when due (off the hot path)."""
        now = time.monotonic()
        if now < self._next:
            return
        self._next = now + self.period
        counters, state = report()
        rates = {}
        if self._previous is not None:
            then, before = self._previous
            rates = {k: round((v - before.get(k, 0)) / (now - then), 1) for k, v in counters.items()}
        self._previous = (now, dict(counters))
        self._pub.put(encode(Status(self.role, self.name, os.getpid(), counters,
                                    {**state, "rates": rates, "host": HOST})))


def sensor_publisher(session: zenoh.Session, key: str, bulky: bool = False) -> zenoh.Publisher:
    """Latest-only: drop under congestion, send at once (express). The tick path (inputs, proposals,
    commands) goes first; bulky streams (camera frames) go at a lower priority so they never delay it."""
    priority = zenoh.Priority.DATA_LOW if bulky else zenoh.Priority.INTERACTIVE_HIGH
    return session.declare_publisher(key, congestion_control=zenoh.CongestionControl.DROP, express=True,
                                     priority=priority)


def lossless_publisher(session: zenoh.Session, key: str) -> zenoh.Publisher:
    """Lossless: reliable transport, block rather than drop under congestion."""
    return session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK,
                                     reliability=zenoh.Reliability.RELIABLE, priority=zenoh.Priority.DATA)


def wait_matching(publisher: zenoh.Publisher, timeout: float, stop=None) -> bool:
    """A put right after declaring can be lost until a subscriber is matched: wait for one."""
    return bool(poll(lambda: publisher.matching_status.matching, timeout, 0.005, stop))
