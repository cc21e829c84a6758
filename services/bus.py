"""The one place that turns flags into a Zenoh session, plus what every service shares.

Callbacks run on Zenoh's threads: they only append (tag, key, bytes) to an inbox; the service's
own thread decodes, validates and acts, so nothing blocks or calls Zenoh inside a callback.
"""
from __future__ import annotations

import argparse
import faulthandler
import json
import logging
import os
import queue
import signal
import socket
import threading
import time
from collections import Counter
from pathlib import Path

import zenoh

from bus_schema import SchemaError, Status, encode

DEFAULT_ROUTER = "tcp/127.0.0.1:7447"
LOCAL_LISTEN = "tcp/127.0.0.1:0"
DUMP_STACKS = signal.SIGUSR1  # a service asked this prints its threads' stacks to its log
HOST = os.environ.get("DOGGED_HOST") or socket.gethostname()  # the machine a service's status says it runs on


def add_bus_args(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("bus")
    g.add_argument("--connect", action="append", default=None,
                   help=f"router endpoint(s) (default $DOGGED_CONNECT or {DEFAULT_ROUTER})")
    g.add_argument("--listen", action="append", default=None, help="endpoint(s) to listen on")
    g.add_argument("--mode", choices=("auto", "peer", "client", "router"), default="auto",
                   help="peer (direct links to the other services on this machine), client (all via the router), "
                        "router; auto (default): peer when the router is on loopback, else client")
    g.add_argument("--zenoh-config", default=None, help="a Zenoh JSON5 config file applied first")
    add_certificate_args(g)


def add_certificate_args(parser) -> None:
    # (dests of their own: `dogged certs` has an --identity of its own)
    parser.add_argument("--security", dest="cert_dir", default=None, metavar="DIR",
                        help="a `dogged certs` directory holding ca.pem and this identity's key and certificate "
                             "(default $DOGGED_SECURITY): mutual TLS to a secured router")
    parser.add_argument("--identity", dest="cert_identity", default=None, metavar="ROLE.NAME",
                        help="which certificate of it to show, e.g. teacher.alice (default $DOGGED_IDENTITY)")


def use_certificate(args: argparse.Namespace) -> None:
    """--security/--identity stand for $DOGGED_SECURITY/$DOGGED_IDENTITY (zenoh_config reads those)."""
    if getattr(args, "cert_dir", None):
        os.environ["DOGGED_SECURITY"] = args.cert_dir
    if getattr(args, "cert_identity", None):
        os.environ["DOGGED_IDENTITY"] = args.cert_identity


def resolved_mode(mode: str, connect: list[str] | None) -> str:
    """"auto" is peer beside a router on loopback and client towards another machine's: peers listen on
    loopback, so peers on two machines could never link, and the router leaves peers to link themselves."""
    if mode != "auto":
        return mode
    from services.security import is_loopback
    endpoints = connect or [os.environ.get("DOGGED_CONNECT", DEFAULT_ROUTER)]
    return "peer" if all(is_loopback(e) for e in endpoints) else "client"


def zenoh_config(connect=None, listen=None, mode="auto", config_file=None,
                 give_up_after: float | None = None, security: Path | None = None,
                 identity: str | None = None) -> zenoh.Config:
    """Multicast scouting off; explicit endpoints on 127.0.0.1 unless told otherwise. With `security`
    (a `dogged certs` directory; default $DOGGED_SECURITY) and `identity` (this process's certificate;
    default $DOGGED_IDENTITY), mutual TLS, and the router and every peer enforcing who may say what
    (services/security.py): peers link directly, so each checks what reaches it. A service (or a router
    linked to another machine's) keeps trying what it connects to; with `give_up_after` (seconds)
    opening fails instead."""
    secured = security or os.environ.get("DOGGED_SECURITY")
    identity = identity or os.environ.get("DOGGED_IDENTITY")
    mode = resolved_mode(mode, connect)
    conf = zenoh.Config.from_file(config_file) if config_file else zenoh.Config()
    if secured:
        from services.security import secure
        if not identity:
            raise ValueError("DOGGED_SECURITY is set but DOGGED_IDENTITY (this process's certificate) is not")
        # a peer links straight to other peers, so it enforces the access control itself, as the router does
        secure(conf, Path(secured), identity, enforce=mode in ("router", "peer"))
        if mode == "peer":  # other peers link to it over TLS too
            listen = [endpoint.replace("tcp/", "tls/", 1) for endpoint in (listen or [LOCAL_LISTEN])]
    conf.insert_json5("mode", json.dumps(mode))
    conf.insert_json5("scouting/multicast/enabled", "false")
    # a latest-only message waits up to 20 ms for room before it is dropped (default 1 ms): on a
    # busy 2-core machine a sender thread can be descheduled that long without any real congestion
    conf.insert_json5("transport/link/tx/queue/congestion_control/drop/wait_before_drop", "20000")
    if mode == "router":  # it connects only to another machine's router, if told to
        conf.insert_json5("listen/endpoints", json.dumps(listen or [DEFAULT_ROUTER]))
    else:
        connect = connect or [os.environ.get("DOGGED_CONNECT", DEFAULT_ROUTER)]
        if mode == "peer":
            conf.insert_json5("listen/endpoints", json.dumps(listen or [LOCAL_LISTEN]))
    if connect:
        conf.insert_json5("connect/endpoints", json.dumps(connect))
        if give_up_after is None:  # a service: keep trying the router while it starts, and after a partition
            conf.insert_json5("connect/timeout_ms", "-1")
            conf.insert_json5("connect/exit_on_failure", "false")
        else:  # a person's command: say so rather than wait for ever
            conf.insert_json5("connect/timeout_ms", str(int(give_up_after * 1000)))
            conf.insert_json5("connect/exit_on_failure", "true")
    return conf


def config_from_args(args: argparse.Namespace) -> zenoh.Config:
    use_certificate(args)
    return zenoh_config(args.connect, args.listen, args.mode, args.zenoh_config)


class StopFlag:
    """Set by SIGINT/SIGTERM so a service's loop ends and its `with` blocks close cleanly (exit 0)."""

    def __init__(self):
        self._event = threading.Event()
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: self._event.set())
        # SIGUSR1 prints every thread's stack to stderr (the service's log), from C, so it works even
        # while the main thread is stuck in native code: whoever gives up waiting sends it first
        faulthandler.register(DUMP_STACKS, all_threads=True)
        supervisor = os.environ.get("DOGGED_SUPERVISED")
        if supervisor:  # no orphans: if the supervisor dies, even by SIGKILL, its services stop too
            threading.Thread(target=self._watch_parent, args=(int(supervisor),), daemon=True).start()

    def _watch_parent(self, supervisor_pid: int) -> None:
        while not self._event.wait(0.5):
            if os.getppid() != supervisor_pid:
                self._event.set()

    def __bool__(self) -> bool:
        return self._event.is_set()

    def set(self) -> None:
        self._event.set()


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
    end = time.monotonic() + timeout
    while time.monotonic() < end and not stop:
        if publisher.matching_status.matching:
            return True
        time.sleep(0.005)
    return publisher.matching_status.matching


def setup_logging(role: str, name: str, level: str = "INFO") -> logging.Logger:
    logging.basicConfig(level=level, format=f"%(asctime)s %(levelname)s {role}/{name}: %(message)s")
    return logging.getLogger(f"dogged.{role}.{name}")


def decode_or_reject(decode_fn, rejects: Rejects, key: str):
    try:
        return decode_fn()
    except SchemaError as err:
        rejects(key, err)
        return None


def ask_owner(session: zenoh.Session, selector: str, timeout: float) -> tuple[bytes | None, str]:
    """Ask every queryable on `selector` (not the nearest only, so the owner is always asked) and
    take the answer if there is exactly one, or all answers are the same bytes: (payload, "").
    Otherwise (None, what went wrong): no answer, only errors, or answers that disagree, which
    means someone besides the owner answers on this key (without access control anyone may)."""
    answers, errors = set(), []
    for reply in session.get(selector, timeout=timeout, target=zenoh.QueryTarget.ALL,
                             consolidation=zenoh.ConsolidationMode.NONE):
        if reply.ok is not None:
            answers.add(reply.ok.payload.to_bytes())
        else:
            errors.append(reply.err.payload.to_bytes()[:200].decode("utf-8", "replace"))
    if len(answers) == 1:
        return answers.pop(), ""
    if answers:
        return None, f"{len(answers)} different answers on {selector}: someone besides its owner answers there"
    return None, f"error from {selector}: {errors[0]}" if errors else f"no answer on {selector}"
