"""Background work takes what the tick path leaves (services/priority.py): a session group's nice read and set as the
kernel holds it, tried again while the kernel says to wait; a learner yielding while it learns its history and back
at nice 0 once it serves; a GP's fitting process in a session of its own at YIELDING_NICE, its learner's as it was."""
import os
import subprocess
import sys

import numpy as np
import pytest

from rigs.harness import REPO
from services import priority
from services.priority import YIELDING_NICE, ShareWatch, group_nice, set_group_nice, stop_yielding, yield_cpus

HAS_AUTOGROUP = os.path.exists(priority.AUTOGROUP)


class Autogroup:
    """/proc/self/autogroup as a file: a write after `busy` refusals (EAGAIN) is what a read gives."""

    def __init__(self, tmp_path, busy=0):
        self.path, self.busy, self.writes = tmp_path / "autogroup", busy, 0
        self.path.write_text("/autogroup-42 nice 0\n")

    def open(self, path, mode="r"):
        if "w" not in mode:
            return open(path, mode)
        self.writes += 1
        if self.busy:
            self.busy -= 1
            raise BlockingIOError(11, "Resource temporarily unavailable")
        return Writer(path)


class Writer:
    def __init__(self, path):
        self.path = path

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def write(self, text):  # as the kernel spells what it holds
        with open(self.path, "w") as f:
            f.write(f"/autogroup-42 nice {int(text)}\n")


def fake(monkeypatch, tmp_path, busy=0) -> Autogroup:
    group = Autogroup(tmp_path, busy)
    monkeypatch.setattr(priority, "open", group.open, raising=False)
    monkeypatch.setattr(priority, "RETRY_S", 0.0)
    return group


def test_the_group_nice_is_read_as_the_kernel_spells_it_and_anything_else_is_none(tmp_path):
    path = tmp_path / "autogroup"
    path.write_text("/autogroup-3993 nice 19\n")
    assert group_nice(str(path)) == 19
    for text in ("", "/autogroup-1 nice", "garbage here"):
        path.write_text(text)
        assert group_nice(str(path)) is None
    assert group_nice(str(tmp_path / "absent")) is None


def test_a_change_the_kernel_refuses_for_now_is_tried_again_and_said_held_only_once_it_is(monkeypatch, tmp_path):
    group = fake(monkeypatch, tmp_path, busy=3)
    assert set_group_nice(19, str(group.path)) and group.writes == 4 and group_nice(str(group.path)) == 19
    group = fake(monkeypatch, tmp_path, busy=10)
    assert not set_group_nice(0, str(group.path), tries=5) and group.writes == 5
    assert not set_group_nice(19, str(tmp_path / "nowhere" / "autogroup")), "no autogroup: nothing held"


def test_only_a_process_leading_its_own_session_yields_its_group(monkeypatch, tmp_path):
    group = fake(monkeypatch, tmp_path)
    monkeypatch.setattr(priority, "leads_its_session", lambda: False)
    assert not yield_cpus(str(group.path)) and group.writes == 0, "a terminal's session is not its to slow down"
    monkeypatch.setattr(priority, "leads_its_session", lambda: True)
    assert yield_cpus(str(group.path)) and group_nice(str(group.path)) == YIELDING_NICE
    assert stop_yielding(str(group.path)) and group_nice(str(group.path)) == 0


def learner_with_a_backlog(monkeypatch, back=lambda tries: True):
    """A learner node with 20 pairs to catch up on, its CPUs left alone; each yield and each try to come back
    (with its tries) noted in the list returned beside it."""
    from services.boxes import learner as learner_box
    from tests.test_learner_box import pair
    from tests.test_learner_catch_up import node
    calls = []
    monkeypatch.setattr(learner_box, "yield_cpus", lambda: calls.append("yield") or True)
    monkeypatch.setattr(learner_box, "stop_yielding", lambda tries: calls.append(("back", tries)) or back(tries))
    monkeypatch.setattr(learner_box, "to_every_cpu", lambda: None)
    monkeypatch.setattr(learner_box, "take_own_cpus", lambda: None)
    n, _ = node()
    n.replay([pair(s) for s in range(1, 21)])
    return n, calls


def test_a_learner_yields_while_it_learns_its_history_and_not_once_it_serves(monkeypatch):
    from tests.test_learner_box import pair
    refusals = iter([True, True])  # the kernel refuses twice, then allows
    n, calls = learner_with_a_backlog(monkeypatch, lambda tries: not next(refusals, False))
    n.catch_up(0.0)
    assert calls == ["yield"] and n.backlog
    while n.backlog:
        n.catch_up(0.0)
    assert n.serving_live and calls == ["yield", ("back", 5)], "tried for a tenth of a second"
    n.handle([])
    n.handle([])
    assert calls == ["yield", ("back", 5), ("back", 1), ("back", 1)], "then once a batch until it holds"
    n.handle([])
    n.on_pair(pair(21))
    n.catch_up(0.0)
    assert len(calls) == 4, "held: nothing more; taught live is the tick path's work, not yielded"
    assert np.isfinite(n.wait())


def test_a_share_watch_says_starved_once_a_window_held_less_than_its_share_of_a_core():
    wall, cpu = [0.0], [0.0]
    watch = ShareWatch(share=0.25, window_s=2.0, clock=lambda: wall[0], cpu=lambda: cpu[0])
    wall[0], cpu[0] = 1.9, 0.0
    assert not watch.starved() and watch.last_share is None, "no window over yet: nothing said"
    wall[0], cpu[0] = 2.0, 1.0
    assert not watch.starved() and watch.last_share == 0.5
    wall[0], cpu[0] = 4.0, 1.4  # 0.4 s of CPU in the next 2 s
    assert watch.starved() and watch.last_share == pytest.approx(0.2)


class Starving:
    """A ShareWatch whose second look says the machine is full."""

    def __init__(self):
        self.last_share, self.window_s, self.looks = 0.05, 2.0, 0

    def starved(self):
        self.looks += 1
        return self.looks == 2


def test_a_learner_catching_up_on_a_full_machine_stops_yielding_and_learns_on(monkeypatch):
    from services.boxes import learner as learner_box
    monkeypatch.setattr(learner_box, "ShareWatch", Starving)
    n, calls = learner_with_a_backlog(monkeypatch)
    n.catch_up(0.0)
    n.catch_up(0.0)
    assert calls == ["yield"] and not n.serving_live, "a share held: still yielding"
    n.catch_up(0.0)
    assert calls == ["yield", ("back", 5)] and n.counts["yield_starved"] == 1 and n.backlog
    while n.backlog:
        n.catch_up(0.0)
    assert n.serving_live and calls == ["yield", ("back", 5)], "back already: nothing more once it serves"


FITTER = """
import os
from services import priority
before = (os.getsid(0), priority.group_nice())
held = priority.become_background_process()
print(before[0] != os.getpid(), held, os.getsid(0) == os.getpid(), priority.group_nice(), os.nice(0))
"""


@pytest.mark.live
@pytest.mark.skipif(not HAS_AUTOGROUP, reason="no /proc/self/autogroup on this kernel")
def test_a_fitting_process_gets_a_session_of_its_own_at_the_yielding_nice_and_its_parents_is_as_it_was():
    parent_nice = group_nice()
    done = subprocess.run([sys.executable, "-c", FITTER], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["True", "True", "True", str(YIELDING_NICE), str(YIELDING_NICE)]
    assert group_nice() == parent_nice


SERVICE = """
import os
from services import priority
print(priority.yield_cpus(), priority.group_nice(), priority.stop_yielding(), priority.group_nice())
"""


@pytest.mark.live
@pytest.mark.skipif(not HAS_AUTOGROUP, reason="no /proc/self/autogroup on this kernel")
def test_a_service_leading_its_session_yields_and_comes_back_unprivileged():
    done = subprocess.run([sys.executable, "-c", SERVICE], cwd=REPO, capture_output=True, text=True, timeout=60,
                          start_new_session=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["True", str(YIELDING_NICE), "True", "0"]


BESIDE_PROBE = 'import os, sys; from services import priority; ' \
               'print(os.getsid(0) == os.getpid(), priority.group_nice(), os.nice(0)); ' \
               'sys.exit(3)'


@pytest.mark.live
@pytest.mark.skipif(not HAS_AUTOGROUP, reason="no /proc/self/autogroup on this kernel")
def test_make_tests_tiers_beside_the_live_one_run_in_a_session_of_their_own_at_19_and_their_exit_code_counts():
    before = group_nice()
    done = subprocess.run(["sh", "rigs/beside.sh", sys.executable, "-c", BESIDE_PROBE], cwd=REPO,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 3, done.stderr  # make test judges the tiers by it
    assert done.stdout.split() == ["True", "19", "19"]
    assert group_nice() == before  # the session that ran it was left as it was
