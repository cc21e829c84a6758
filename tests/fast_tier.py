"""`make check`'s fast tier: every test that starts no process and takes a second at most (issue 32).

A test that starts a process (the `dogged` CLI, a box, a router, chromium: `subprocess`, `os.fork`,
`multiprocessing`) or opens a Zenoh session is marked `live`: by `pytestmark = pytest.mark.live` in its
module, `@pytest.mark.live` on it, or by asking for a fixture of LIVE_FIXTURES. One that starts none but
simulates or teaches for longer (over a second on this project's 2 shared cores, or a suite run once
more at seconds' cost) is marked `slow`. `pytest --fast-tier` leaves both out and polices the rest:
every way to start a process or a session raises, and a test whose setup and call use over CEILING_S of
CPU fails, each naming the mark to add. (CPU time, not wall time: other work on the machine must not
fail a test; make check's --durations=5 shows a test that waits.) So a test put in the wrong tier fails
`make check` rather than slowing it, and `make test` (no flag) runs every test as before."""
from __future__ import annotations

import multiprocessing.process
import os
import subprocess
import time

import pytest
import zenoh

FLAG = "--fast-tier"
REST = "--rest-of-tiers"  # the other half: what the fast tier leaves out
LIVE_FIXTURES = {"router"}  # conftest's fixtures that start a process: a test asking for one is live
MARKS = {"live": "starts a process or opens a Zenoh session; `make test` runs it, `make check` leaves it out",
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
    parser.addoption(REST, action="store_true", help=f"every test {FLAG} leaves out (marked live or slow, or asking "
                     "for a fixture that starts a process): make test runs these beside the fast tier")


def pytest_configure(config):
    for mark, meaning in MARKS.items():
        config.addinivalue_line("markers", f"{mark}: {meaning}")


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    for item in items:
        if LIVE_FIXTURES & set(item.fixturenames):
            item.add_marker(pytest.mark.live)
    if config.getoption(FLAG) and config.getoption(REST):
        raise pytest.UsageError(f"{FLAG} and {REST} are the two halves of the tests: ask for one")
    if not (config.getoption(FLAG) or config.getoption(REST)):
        return
    rest = config.getoption(REST)  # the marked tests; the fast tier: the others
    marked = [any(item.get_closest_marker(mark) for mark in MARKS) for item in items]
    config.hook.pytest_deselected(items=[item for item, m in zip(items, marked) if m != rest])
    items[:] = [item for item, m in zip(items, marked) if m == rest]
    if config.getoption(FLAG):
        _Guard(config)


def _advice(mark: str) -> str:
    return (f"mark it {mark} (`@pytest.mark.{mark}`, or `pytestmark = pytest.mark.{mark}` for its module) "
            "so that only make test runs it")


class _Guard:
    """Closes every door (a call there records the attempt on the running test and raises), and fails a
    test whose refusal was caught, or that went over the ceiling."""

    def __init__(self, config):
        self.running: pytest.Item | None = None
        self.attempts: dict[str, list[str]] = {}  # test id -> the doors it tried
        self.cpu_at_start = 0.0  # the running test's: time.process_time() as its setup began
        self.ceiling_s = CEILING_S
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

    @staticmethod
    def _started(test: str, doors: list[str]) -> str:
        return (f"{test} is in make check's fast tier but started a process or a Zenoh session "
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
        elif cpu > self.ceiling_s:
            report.outcome = "failed"
            report.longrepr = (f"{item.nodeid} is in make check's fast tier but used {cpu:.1f} s of CPU (setup and "
                               f"call), over its {self.ceiling_s:g} s: {_advice('slow')}")
