"""How much of a contended CPU a process's background work takes: none that another process wakes wanting.

Linux schedules each session as one group (autogroup: every service leads its own session, started so by its
supervisor), so a process's own nice weighs only against its own session; a session's weight is the nice of
its group (/proc/self/autogroup), which an unprivileged process may raise and lower again (once per 100 ms, over
all processes). A GP's fits and a learner learning its history before it serves took a core beside the tick path
(the router, the recorder and the page on the background CPUs; the tick path's own while catching up): in the
mirroring soak's hour the tick's minute p99 was 15-24 ms in each minute they ran, 6-10 ms in the others
(docs/results.md). At a group nice above 0, a process waking on the same CPU preempts them: two processes
ping-ponging every 5 ms beside a core's spinner, round trip p99 3.0-3.8 ms with the spinner at group nice 0,
0.12-0.30 at 5, 10, 15 or 19 alike. What the level sets is their share where the others want the whole CPU (a
spinner beside one at 0: 25 % at 5, 10 % at 10, 2.6 % at 19), and at 19 the quick soak's swaps in a CI, both
profiles side by side, took 53.8 s (knn), 20.3 (LWPR) and 67.2 (the wired GP): so 5.

Best effort: where there is no such file (another kernel, another system) nothing changes.
"""
from __future__ import annotations

import logging
import os
import time

AUTOGROUP = "/proc/self/autogroup"
YIELDING_NICE = 5  # (above)
# yielding is worth it while the work still gets this share of a core, looked at over each window: below it the
# machine is full (two profiles side by side, a CI), the tick waits on everyone anyway, and the work only stops
# (a CI's quick soak: a swap's catch-up 110 s at nice 5, 32-67 s at 0)
STARVED_SHARE, STARVED_WINDOW_S = 0.25, 2.0
RETRY_S, TRIES = 0.02, 50  # the kernel's limit: one change of any group's nice per 100 ms, over all processes

log = logging.getLogger(__name__)


def group_nice(path: str = AUTOGROUP) -> int | None:
    """This process's group's nice as the kernel holds it ("/autogroup-42 nice 19"), None where unknown."""
    try:
        with open(path) as f:
            return int(f.read().split()[-1])
    except (OSError, ValueError, IndexError):
        return None


def set_group_nice(nice: int, path: str = AUTOGROUP, tries: int = TRIES) -> bool:
    """This process's session group to `nice`, trying again while the kernel says to wait; whether it holds."""
    for _attempt in range(tries):
        try:
            with open(path, "w") as f:
                f.write(str(nice))
            return group_nice(path) == nice
        except BlockingIOError:  # EAGAIN: another group's nice changed within 100 ms
            time.sleep(RETRY_S)
        except OSError:  # no autogroup here, or not ours to change
            return False
    return False


def leads_its_session() -> bool:
    """Whether this process's session is its own (a supervised service): a process run by hand shares its
    terminal's, whose group it must not slow down."""
    return os.getsid(0) == os.getpid()


def yield_cpus(path: str = AUTOGROUP) -> bool:
    """For background work in a service's own process (a learner's catch-up): its session's group at YIELDING_NICE,
    until stop_yielding; False where it cannot be (not its own session, no autogroup)."""
    return leads_its_session() and set_group_nice(YIELDING_NICE, path)


def stop_yielding(path: str = AUTOGROUP, tries: int = TRIES) -> bool:
    """Back to nice 0 (the process serves the tick path again); whether it holds."""
    return set_group_nice(0, path, tries)


def become_background_process(path: str = AUTOGROUP) -> bool:
    """For a process that does background work all its life (a GP's fitting process, spawned by its learner):
    a session of its own at group nice YIELDING_NICE, and its own nice as well where the kernel groups no
    sessions. Its learner's session is left as it was."""
    try:
        os.setsid()
    except OSError:  # already leads a session: its own
        pass
    try:
        os.nice(YIELDING_NICE - os.nice(0))
    except OSError:
        pass
    held = yield_cpus(path)
    if not held:
        log.debug("no session group to lower here: fits at nice %d", os.nice(0))
    return held


class ShareWatch:
    """Whether this process got at least `share` of a core (its CPU time over the wall time) in each `window_s`."""

    def __init__(self, share: float = STARVED_SHARE, window_s: float = STARVED_WINDOW_S,
                 clock=time.monotonic, cpu=time.process_time):
        self.share, self.window_s, self.clock, self.cpu = share, window_s, clock, cpu
        self._since = (clock(), cpu())
        self.last_share: float | None = None

    def starved(self) -> bool:
        """True once a window is over with less than `share`; False until a window is over."""
        now = self.clock()
        wall = now - self._since[0]
        if wall < self.window_s:  # (looked at every slice of a catch-up: the CPU time only once a window is over)
            return False
        used = self.cpu()
        self.last_share, self._since = (used - self._since[1]) / wall, (now, used)
        return self.last_share < self.share
