"""Real processes on a real router on loopback, for integration tests and benchmarks."""
from __future__ import annotations

import collections
import contextlib
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import zenoh

from bus_schema import EVERY_STATUS, InstanceKeys, Status, decode
from rigs.headless import missing_chromium
from services import waiting
from services.bus.config import zenoh_config
from services.bus.publishers import lossless_publisher, wait_matching
from services.demo.live import switch_teaching
from services.own_identities import HOME_ENV
from services.supervisor.commands import wait_announced
from services.supervisor.process import dump_stacks_then_kill

REPO = Path(__file__).resolve().parents[1]

# a profile's loop beside its platform: a sine teacher teaching from the start, an LWPR learner, the arbitrator
LOOP_SERVICES = """
[services.teacher]
box = "demonstrator"
args = ["--teacher", "sine", "--on"]

[services.learner]
box = "learner"
args = ["--learner", "lwpr"]

[services.arbitrator]
box = "arbitrator"
"""

# the page's tests: skipped, saying what to install, where there is no chromium (make test as a user)
needs_chromium = pytest.mark.skipif(missing_chromium() is not None, reason=str(missing_chromium()))


def wait_until(condition, timeout: float, what: str = "condition", poll: float = 0.05):
    """condition()'s first truthy value within `timeout` seconds, else an AssertionError naming `what`."""
    value = waiting.poll(condition, timeout, poll)
    if value is None:
        raise AssertionError(f"timed out after {timeout} s waiting for {what}")
    return value


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def dogged(*args: str, log: Path | None = None, env: dict | None = None) -> subprocess.Popen:
    """`dogged <args>` started; for `up`, returned once a profile secured by this user's own identities has
    announced its router (a test's session opened before would speak plain TCP to a TLS router), or up
    has ended (a profile it refused)."""
    out = open(log, "ab") if log else subprocess.DEVNULL
    proc = subprocess.Popen([sys.executable, "-m", "services.cli", *args], cwd=REPO, stdout=out,
                            stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, env={**os.environ, **(env or {})})
    if args and args[0] == "up" and not (env or {}).get(HOME_ENV):
        router = args[args.index("--router") + 1] if "--router" in args else None
        with contextlib.suppress(RuntimeError, ValueError):  # it exited, or refused the profile: the test reads why
            wait_announced(Path(args[1]), router, proc)
    return proc


def dogged_ok(*args: str, endpoint: str, timeout: float = 60) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "services.cli", "--connect", endpoint, *args], cwd=REPO,
                          capture_output=True, text=True, timeout=timeout)


def stop(*procs: subprocess.Popen, timeout: float = 10) -> list[int]:
    for p in procs:
        if p.poll() is None:
            p.terminate()
    codes = []
    for p in procs:
        try:
            codes.append(p.wait(timeout))
        except subprocess.TimeoutExpired:  # its log then shows where it was stuck
            codes.append(dump_stacks_then_kill(p))
    return codes


MAIN = InstanceKeys("main")


class Probe:
    """A client session in the test process: the latest status of every service, raw puts."""

    def __init__(self, endpoint: str):
        self.session = zenoh.open(zenoh_config(connect=[endpoint], mode="client"))
        self.status: dict[str, Status] = {}
        self.reports: collections.Counter = collections.Counter()  # statuses heard, per member
        self.samples: dict[str, list] = {}
        self._lock = threading.Lock()
        self._teach = None  # (teach)
        self.session.declare_subscriber(EVERY_STATUS, self._on_status)

    def _on_status(self, sample):
        try:
            msg = decode(Status, sample.payload.to_bytes(), str(sample.key_expr))
        except ValueError:
            return
        with self._lock:
            self.status[f"{msg.role}/{msg.name}"] = msg
            self.reports[f"{msg.role}/{msg.name}"] += 1

    def record(self, key: str):
        """Keep every payload seen on `key` (list of (key, bytes, arrival time))."""
        bucket = self.samples.setdefault(key, [])
        self.session.declare_subscriber(key, lambda s: bucket.append(
            (str(s.key_expr), s.payload.to_bytes(), time.monotonic())))
        return bucket

    def counter(self, member: str, name: str, default=0):
        with self._lock:
            msg = self.status.get(member)
        return msg.counters.get(name, default) if msg else default

    def state(self, member: str, name: str, default=None):
        with self._lock:
            msg = self.status.get(member)
        return msg.state.get(name, default) if msg else default

    def wait_for(self, condition, timeout: float, what: str = "condition"):
        return wait_until(condition, timeout, what)

    def wait_for_fresh_status(self, *members: str, timeout: float = 15.0) -> None:
        """Until each member's status is heard twice more: the first may have been on its way already,
        the second was made after this call, so its counters hold everything done before it."""
        with self._lock:
            wanted = {m: self.reports[m] + 2 for m in members}
        wait_until(lambda: all(self.reports[m] >= n for m, n in wanted.items()), timeout,
                   f"a fresh status of {', '.join(members)}")

    def put(self, key: str, payload: bytes) -> None:
        # lossless on purpose: a test counts what arrives, so the sender must not drop under congestion
        pub = self.session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK,
                                             reliability=zenoh.Reliability.RELIABLE)
        wait_matching(pub, 3.0)
        pub.put(payload)
        pub.undeclare()

    def teach(self, on: bool) -> None:
        """Every teacher of instance main on or off, as the page's switch does (services.demo.live.switch_teaching)."""
        if self._teach is None:
            self._teach = lossless_publisher(self.session, MAIN.teach)
        switch_teaching(self.session, self._teach, MAIN, on)

    def close(self):
        self.session.close()
