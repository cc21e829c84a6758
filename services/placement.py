"""Where a profile's processes run: the tick path on CPUs of its own, everything else on the others.

A tick is a chain (platform -> learner -> arbitrator -> platform, with perception, teachers and a chain's
upper level on the way): one process at a time works on it. The recorder, the page, the handler, the
router and a learner's fitting processes wake on the same samples, and on a machine of few cores they
took the cores the tick's next process waited for. Given a core of its own the tick path was faster on
mirroring as deployed (docs/results.md, "The tick path on a CPU of its own"; 2 cores, three alternated rounds):
the platform's own p50 while the student drove 3.27-3.48 -> 2.74-2.84 ms, its p99 while taught 10.8-11.9 ->
6.4-8.3 ms.

`[profile] tick_cpus`: "auto" (the default: the upper half of the CPUs the supervisor may use, when it may
use two or more), "off" (every process anywhere, as the kernel likes), or a list of CPU numbers. The
supervisor gives each service its CPUs in its environment (CPUS_ENV, and BACKGROUND_ENV: where its
background work goes), and every dogged process takes them at its start (services/__init__.py), before
it has a thread: the threads it makes after inherit them. A GP's fitting processes work on the background
CPUs. A learner learning its history before it serves (a restart's log, a swap's history: minutes of a core)
may use every CPU given until it serves live: kept to the background ones it shared one core with the
recorder, the page and the browser, and an hour's swaps took 1.7-3x as long (knn 3.5 -> 5.8 s, LWPR 4.5 ->
13.7 s on the soak's history; the wired per-output GP 256 -> 609 s, a CI running beside it), while the old
learner served anyway. Both take of a CPU only what the tick path leaves (services/priority.py).
"""
from __future__ import annotations

import os
from dataclasses import dataclass

CPUS_ENV, BACKGROUND_ENV = "DOGGED_CPUS", "DOGGED_BACKGROUND_CPUS"
# the boxes a tick passes through, and those that route it, record it, show it or move the world: every box is
# one or the other (tests/test_placement.py), put there by whoever adds it
TICK_PATH_BOXES = frozenset({"platform", "aibo", "perception", "learner", "arbitrator", "demonstrator", "chain"})
OFF_PATH_BOXES = frozenset({"router", "recorder", "ui", "handler"})


class PlacementError(ValueError):
    """A tick_cpus the supervisor cannot honour, saying why."""


@dataclass(frozen=True)
class Placement:
    tick: frozenset[int]  # the tick path's CPUs
    rest: frozenset[int]  # everything else's

    def env_for(self, box: str) -> dict[str, str]:
        """The environment that puts a process of `box` where it goes (a KeyError for a box placed nowhere)."""
        own = self.tick if box in TICK_PATH_BOXES else self.rest if box in OFF_PATH_BOXES else None
        if own is None:
            raise KeyError(f"box {box!r} is placed neither on the tick path nor off it (services/placement.py)")
        return {CPUS_ENV: spell(own), BACKGROUND_ENV: spell(self.rest)}

    def describe(self) -> str:
        return f"the tick path ({', '.join(sorted(TICK_PATH_BOXES))}) on CPU {spell(self.tick)}, " \
               f"everything else on CPU {spell(self.rest)}"


def plan(tick_cpus, allowed: set[int] | None = None) -> Placement | None:
    """The placement a profile's `tick_cpus` asks for among the CPUs `allowed` (the supervisor's own), or
    None: "off", or "auto" with fewer than two CPUs. PlacementError names what is wrong."""
    allowed = set(os.sched_getaffinity(0) if allowed is None else allowed)
    if tick_cpus == "off":
        return None
    if tick_cpus == "auto":
        if len(allowed) < 2:
            return None
        ordered = sorted(allowed)
        half = len(ordered) // 2
        return Placement(frozenset(ordered[-half:]), frozenset(ordered[:-half]))
    if not isinstance(tick_cpus, list) or not tick_cpus or not all(
            isinstance(c, int) and not isinstance(c, bool) for c in tick_cpus):
        raise PlacementError(f'expected "auto", "off" or a list of CPU numbers, got {tick_cpus!r}')
    tick = set(tick_cpus)
    if len(tick) != len(tick_cpus):
        raise PlacementError(f"CPU numbers repeat in {tick_cpus}")
    if not tick <= allowed:
        raise PlacementError(f"CPU {spell(tick - allowed)} not among those this process may use ({spell(allowed)})")
    if tick == allowed:
        raise PlacementError(f"every CPU this process may use ({spell(allowed)}) is the tick path's: leave at "
                             "least one for the recorder, the page and the rest")
    return Placement(frozenset(tick), frozenset(allowed - tick))


def spell(cpus) -> str:
    return ",".join(str(c) for c in sorted(cpus))


def cpus_of(pid: int | None) -> str:
    """The CPUs process `pid` (its main thread) may run on, spelled; "" when it is gone or cannot be asked."""
    try:
        return spell(os.sched_getaffinity(pid)) if pid else ""
    except (OSError, AttributeError):
        return ""


def read(text: str | None) -> set[int] | None:
    """CPUs as spelled in the environment ("1" or "2,3"); None when unset or not such a list."""
    try:
        cpus = {int(part) for part in (text or "").split(",") if part.strip()}
    except ValueError:
        return None
    return cpus or None


def move_process(cpus: set[int] | None) -> bool:
    """Every thread of this process onto `cpus` (threads made later inherit their maker's); False where it
    cannot be (no such call on this system, CPUs not ours any more): the process runs where it did."""
    if not cpus or not hasattr(os, "sched_setaffinity"):
        return False
    try:
        threads = [int(t) for t in os.listdir("/proc/self/task")]
    except OSError:
        threads = [0]
    moved = False
    for thread in threads:
        try:
            os.sched_setaffinity(thread, cpus)
            moved = True
        except OSError:  # a thread that ended meanwhile; CPUs taken away (a cgroup's cpuset changed)
            pass
    return moved


def take_own_cpus() -> bool:
    """At a dogged process's start: onto the CPUs its supervisor gave it (CPUS_ENV), if any."""
    return move_process(read(os.environ.get(CPUS_ENV)))


def to_background() -> bool:
    """Onto the background CPUs (a GP's fitting process), if the supervisor gave any."""
    return move_process(read(os.environ.get(BACKGROUND_ENV)))


def to_every_cpu() -> bool:
    """Onto its own CPUs and the background ones (a learner learning its history before it serves)."""
    own, background = read(os.environ.get(CPUS_ENV)), read(os.environ.get(BACKGROUND_ENV))
    return move_process((own or set()) | (background or set()))
