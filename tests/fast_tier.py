"""`make check`'s fast tier: every test that starts no process and takes a second at most (issue 32).

A test that starts a process (the `dogged` CLI, a box, a router, chromium: `subprocess`, `os.fork`,
`multiprocessing`) or opens a Zenoh session is marked `live`: by `pytestmark = pytest.mark.live` in its
module, `@pytest.mark.live` on it, or by asking for a fixture of LIVE_FIXTURES. One that starts none but
simulates or teaches for longer (over a second on this project's 2 shared cores, or a suite run once
more at seconds' cost) is marked `slow`. `pytest --fast-tier` leaves both out and polices the rest:
every way to start a process or a session raises, and a test whose setup and call use over CEILING_S of
CPU fails, each naming the mark to add. (CPU time, not wall time: other work on the machine must not
fail a test; make check's --durations=5 shows a test that waits.) So a test put in the wrong tier fails
`make check` rather than slowing it, and `make test` (no flag) runs every test as before.

`make test` runs three tiers: the live tests (`--live-tier`) at the machine's priority, and beside them at
the lowest, the fast tier then the slow one (`--slow-tier`: the tests marked slow and not live, whose doors
are closed as the fast tier's, without its CPU ceiling). `--rest-of-tiers` is the slow and the live ones."""
from __future__ import annotations

import multiprocessing.process
import os
import subprocess
import time

import pytest
import zenoh

FLAG = "--fast-tier"
SLOW = "--slow-tier"  # the tests marked slow and not live: no process either, any CPU
LIVE = "--live-tier"  # the tests marked live (or asking for a router)
REST = "--rest-of-tiers"  # the slow and the live ones: what the fast tier leaves out
TIERS = {FLAG: ("fast",), SLOW: ("slow",), LIVE: ("live",), REST: ("slow", "live")}
LIVE_FIXTURES = {"router"}  # conftest's fixtures that start a process: a test asking for one is live
MARKS = {"live": "starts a process or opens a Zenoh session, or judges wall time: `make test` runs it at the "
                 "machine's priority, `make check` leaves it out",
         "slow": "starts no process but takes seconds; `make test` runs it, `make check` leaves it out"}
CEILING_S = 5.0  # of CPU time (every thread's), a tier test's setup and call: five times the mark's second

# every door a test could start a process or a session by: (owner, attribute, what a refusal calls it)
DOORS = (
    (subprocess.Popen, "__init__", "subprocess.Popen (subprocess.run, asyncio's subprocesses, Playwright)"),
    (os, "fork", "os.fork (os.spawn*)"),
    (os, "forkpty", "os.forkpty"),
    (os, "system", "os.system"),
    (os, "posix_spawn", "os.posix_spawn"),
    (os, "posix_spawnp", "os.posix_spawnp"),
    (multiprocessing.process.BaseProcess, "start", "multiprocessing (Process.start, process pools)"),
    (zenoh, "open", "zenoh.open"),
)


class StartsAProcess(RuntimeError):
    """A test of the fast tier started a process or opened a Zenoh session."""


def pytest_addoption(parser):
    parser.addoption(FLAG, action="store_true", help="make check's tier: leave out the tests marked live or "
                     f"slow, and fail any other that starts a process or uses over {CEILING_S:.0f} s of CPU")
    parser.addoption(SLOW, action="store_true", help="the tests marked slow and not live: make test runs them at the "
                     "lowest priority after the fast tier, beside the live tests; one that starts a process fails")
    parser.addoption(LIVE, action="store_true", help="the tests marked live, or asking for a fixture that starts a "
                     "process: make test runs these at the machine's priority")
    parser.addoption(REST, action="store_true", help=f"every test {FLAG} leaves out: those of {SLOW} and {LIVE}")


def pytest_configure(config):
    for mark, meaning in MARKS.items():
        config.addinivalue_line("markers", f"{mark}: {meaning}")


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    for item in items:
        if LIVE_FIXTURES & set(item.fixturenames):
            item.add_marker(pytest.mark.live)
    asked = [flag for flag in TIERS if config.getoption(flag)]
    if len(asked) > 1:
        raise pytest.UsageError(f"{' and '.join(asked)}: the tiers do not overlap, ask for one")
    if not asked:
        return
    wanted = TIERS[asked[0]]
    tiers = [_tier(item) for item in items]
    config.hook.pytest_deselected(items=[item for item, tier in zip(items, tiers) if tier not in wanted])
    items[:] = [item for item, tier in zip(items, tiers) if tier in wanted]
    guarded = {FLAG: ("make check's fast tier", CEILING_S),
               SLOW: ("the slow tier (no process: it runs beside the live tests, at the lowest priority)", None)}
    if asked[0] in guarded:
        _Guard(config, *guarded[asked[0]])


def _tier(item) -> str:
    return "live" if item.get_closest_marker("live") else "slow" if item.get_closest_marker("slow") else "fast"


def _advice(mark: str) -> str:
    return (f"mark it {mark} (`@pytest.mark.{mark}`, or `pytestmark = pytest.mark.{mark}` for its module) "
            "so that only make test runs it")


class _Guard:
    """Closes every door (a call there records the attempt on the running test and raises), and fails a
    test whose refusal was caught, or that went over the ceiling."""

    def __init__(self, config, tier: str, ceiling_s: float | None):
        self.tier, self.ceiling_s = tier, ceiling_s
        self.running: pytest.Item | None = None
        self.attempts: dict[str, list[str]] = {}  # test id -> the doors it tried
        self.cpu_at_start = 0.0  # the running test's: time.process_time() as its setup began
        monkeypatch = pytest.MonkeyPatch()
        config.add_cleanup(monkeypatch.undo)
        for owner, name, what in DOORS:
            if hasattr(owner, name):
                monkeypatch.setattr(owner, name, self._refusal(what))
        config.pluginmanager.register(self, "fast-tier-guard")

    def _refusal(self, what: str):
        def refuse(*args, **kwargs):
            test = self.running.nodeid if self.running else "(between tests)"
            self.attempts.setdefault(test, []).append(what)
            raise StartsAProcess(self._started(test, [what]))
        return refuse

    def _started(self, test: str, doors: list[str]) -> str:
        return (f"{test} is in {self.tier} but started a process or a Zenoh session "
                f"({', '.join(dict.fromkeys(doors))}): {_advice('live')}")

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(self, item, nextitem):
        self.running, self.cpu_at_start = item, time.process_time()
        yield
        self.running = None

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_makereport(self, item, call):
        report = (yield).get_result()
        if report.when != "call" or report.failed:
            return
        doors = self.attempts.get(item.nodeid)  # a refusal the test caught (a broad except, pytest.raises)
        cpu = time.process_time() - self.cpu_at_start
        if doors:
            report.outcome, report.longrepr = "failed", self._started(item.nodeid, doors)
        elif self.ceiling_s is not None and cpu > self.ceiling_s:
            report.outcome = "failed"
            report.longrepr = (f"{item.nodeid} is in {self.tier} but used {cpu:.1f} s of CPU (setup and "
                               f"call), over its {self.ceiling_s:g} s: {_advice('slow')}")
