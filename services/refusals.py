"""Refusals of identities not on the roster (issue 30): Zenoh refuses them inside its own code, so
they are read from Zenoh's log.

Every process that enforces access control (a router, a peer) has Zenoh log, on its stdout, the two
lines that tell a refusal: the TLS (or QUIC) link accepted with the certificate's common name, and the
access control's word that the transport matched no subject, so that nothing it sends or would
receive passes. Its supervisor reads every line of its services (ManagedProcess) and counts, per
service, the refusals with the name each certificate showed; `dogged ps` shows them.
"""
from __future__ import annotations

import collections
import logging
import os
import re
import threading

# what Zenoh 1.x writes (zenoh_link_tls/quic::unicast at debug, the access control at info; nothing else of
# Zenoh's log, which services did not show before); pinned by
# tests/test_refusals.py against lines a real router wrote
ACCEPTED = re.compile(r"Accepted (?:TLS|QUIC) connection on \S+: (\S+)\. Common Name: (.*)\.$")
UNMATCHED = re.compile(r"(\w+) did not match any configured ACL subject")
ZENOH_LOG = ("off,zenoh_link_tls::unicast=debug,zenoh_link_quic::unicast=debug,"
             "zenoh::net::routing::interceptor::access_control=info")
UNNAMED = "?"  # a refusal whose certificate's name was not logged (a link this process opened itself)


def log_refusals() -> None:
    """Have Zenoh write the lines that tell a refusal on this process's stdout ($RUST_LOG, if set,
    decides instead), without colours: they are read, not watched."""
    import zenoh
    os.environ.setdefault("NO_COLOR", "1")
    zenoh.init_log_from_env_or(ZENOH_LOG)


class Refusals:
    """The refusals one process's log tells of, by the name its certificate showed. note() runs on the
    thread that reads the log; counts() on any other."""

    def __init__(self, roster: list[str], service: str, log: logging.Logger):
        from services.security import known
        self.roster, self.service, self.log = set(known(roster)), service, log
        self.strangers: collections.deque = collections.deque(maxlen=64)  # (name, address) accepted, not yet refused
        self._counts: collections.Counter = collections.Counter()
        self._lock = threading.Lock()

    def note(self, line: str) -> None:
        accepted = ACCEPTED.search(line)
        if accepted and accepted.group(2) not in self.roster:
            self.strangers.append((accepted.group(2), accepted.group(1)))
            return
        unmatched = UNMATCHED.search(line)
        if unmatched is None:
            return
        name, address = self.strangers.popleft() if self.strangers else (UNNAMED, "?")
        with self._lock:
            self._counts[name] += 1
            count = self._counts[name]
        if count <= 10 or count % 100 == 0:
            self.log.warning("%s refused %s from %s (%d so far; Zenoh %s): not on the roster read at `dogged up`, "
                             "it gets nothing; to admit it, `dogged certs` it and restart the profile", self.service,
                             name, address, count, unmatched.group(1))

    def counts(self) -> dict[str, int]:
        with self._lock:
            return dict(self._counts)
