"""A service's life: stopped by SIGINT/SIGTERM or its supervisor's death, its stacks on SIGUSR1, its log."""
from __future__ import annotations

import faulthandler
import logging
import os
import signal
import threading

DUMP_STACKS = signal.SIGUSR1  # a service asked this prints its threads' stacks to its log


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


def setup_logging(role: str, name: str, level: str = "INFO") -> logging.Logger:
    logging.basicConfig(level=level, format=f"%(asctime)s %(levelname)s {role}/{name}: %(message)s")
    return logging.getLogger(f"dogged.{role}.{name}")
