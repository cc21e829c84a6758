"""One supervised OS process: start, log lines prefixed to console and file, restart policy."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from pathlib import Path

from services.bus.lifecycle import DUMP_STACKS
from services.supervisor.profile import ServiceSpec


# a run that lasted this long before it ended was no crash loop: the next failure counts as the first again
# (its backoff from the start, its max_restarts whole), as Kubernetes resets a container's backoff after
# ten minutes of running. `restarts` (what `dogged ps` shows) still counts them all.
HEALTHY_S = 600.0


class ManagedProcess:
    def __init__(self, spec: ServiceSpec, command: list[str], log_dir: Path, echo: bool = True):
        self.spec, self.command, self.echo = spec, command, echo
        self.log_path = log_dir / f"{spec.name}.log"
        self.ready_key: str | None = None  # the liveliness token that says the service is ready
        self.proc: subprocess.Popen | None = None
        self.state = "new"           # starting | ready | backoff | failed | exited | stopped
        self.restarts = 0
        self.in_a_row = 0  # restarts since the last run that lasted HEALTHY_S: what backoff and max_restarts count
        self.started_at = 0.0
        self.restart_at = 0.0
        self.died_at = 0.0  # when the supervisor saw it exit (monotonic)
        self.last_exit: int | str | None = None  # an exit code, or "not ready" (stopped at its ready_timeout_s)
        self.tail: deque[str] = deque(maxlen=2000)
        self.killed = False  # its last stop took a SIGKILL
        self.refusals = None  # services.refusals.Refusals: what its access control refused, read from its log
        self._lock = threading.Lock()

    @property
    def pid(self) -> int | None:
        return self.proc.pid if self.proc and self.proc.poll() is None else None

    def start(self) -> None:
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        env = {**os.environ, **self.spec.env, "DOGGED_SUPERVISED": str(os.getpid()), "PYTHONUNBUFFERED": "1"}
        # a new session: a Ctrl-C in the terminal reaches the supervisor only, which stops services in order
        self.proc = subprocess.Popen(self.command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     stdin=subprocess.DEVNULL, env=env, start_new_session=True)
        self.state, self.started_at, self.killed = "starting", time.monotonic(), False
        self._line(f"--- started pid {self.proc.pid}: {' '.join(self.command)}")
        threading.Thread(target=self._pump, args=(self.proc,), daemon=True).start()

    def _pump(self, proc: subprocess.Popen) -> None:
        for raw in proc.stdout:
            line = raw.decode(errors="replace").rstrip("\n")
            self._line(line)
            if self.refusals is not None:
                self.refusals.note(line)

    def _line(self, text: str) -> None:
        with self._lock:
            self.tail.append(text)
            # this user's alone (0600 from creation): a log can hold the page's token
            with open(os.open(self.log_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o600), "a") as f:
                f.write(text + "\n")
            if self.echo:
                sys.stdout.write(f"[{self.spec.name}] {text}\n")
                sys.stdout.flush()

    def poll(self) -> int | None:
        """The exit code if the process has ended since the last poll, else None."""
        if self.proc is None or self.state in ("backoff", "failed", "exited", "stopped"):
            return None
        code = self.proc.poll()
        if code is not None:
            self.last_exit = code
            self._line(f"--- exited with {code}")
            if time.monotonic() - self.started_at >= HEALTHY_S:
                self.in_a_row = 0
        return code

    def should_restart(self, code: int) -> bool:
        policy = self.spec.restart
        wanted = policy == "always" or (policy == "on-failure" and code != 0)
        return wanted and self.in_a_row < self.spec.max_restarts

    def schedule_restart(self) -> None:
        delay = min(30.0, self.spec.backoff_s * (2 ** self.in_a_row))
        self.restarts += 1
        self.in_a_row += 1
        self.state, self.restart_at = "backoff", time.monotonic() + delay
        self._line(f"--- restart {self.in_a_row}/{self.spec.max_restarts} in {delay:.1f} s"
                   + (f" ({self.restarts} in all)" if self.restarts > self.in_a_row else ""))

    def not_ready(self) -> None:
        """It outlived its ready_timeout_s without becoming ready: stopped, then restarted or failed as a
        failed start would be."""
        self._line(f"--- not ready within {self.spec.ready_timeout_s:g} s: stopped")
        self.stop(timeout=2.0)
        self.last_exit = "not ready"
        if self.should_restart(1):
            self.schedule_restart()
        else:
            self.state = "failed"

    def stop(self, timeout: float = 5.0) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self._line(f"--- did not stop within {timeout:.0f} s: its stacks follow in the log, then SIGKILL")
                dump_stacks_then_kill(self.proc)
                self.killed = True
        self.state = "stopped"

    def describe(self) -> dict:
        alive = self.pid is not None
        return {"name": self.spec.name, "box": self.spec.box, "pid": self.pid or 0, "state": self.state,
                "restarts": self.restarts, "uptime_s": round(time.monotonic() - self.started_at, 1) if alive else 0.0,
                "exit": self.last_exit if self.last_exit is not None else "",
                **({"refused": self.refusals.counts()} if self.refusals is not None else {})}


def dump_stacks_then_kill(proc: subprocess.Popen, grace: float = 1.0) -> int:
    """A service that did not stop: have it print where every thread is (StopFlag registers the
    handler), then kill it. Returns its exit code."""
    try:
        proc.send_signal(DUMP_STACKS)
        proc.wait(grace)
    except (subprocess.TimeoutExpired, ProcessLookupError):
        pass
    proc.kill()
    return proc.wait()
