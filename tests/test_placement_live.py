"""`dogged up` puts the tick path on CPUs of its own (services/placement.py), as the kernel sees it: every thread
of every service where its box goes, a GP learner's fitting processes off the tick path, and `dogged ps` saying so."""
import os

import pytest

from rigs.harness import dogged, dogged_ok, free_port, wait_until
from services.placement import TICK_PATH_BOXES, plan, spell
from services.priority import AUTOGROUP, YIELDING_NICE, group_nice
from tests.test_supervisor import ps

pytestmark = pytest.mark.live

PROFILE = """
[profile]
name = "placed"
log_dir = "{logs}"

[services.platform]
box = "platform"
args = ["--platform", "point", "--param", "dims=2", "--rate", "50"]

[services.teacher]
box = "demonstrator"
args = ["--teacher", "sine", "--on"]

[services.learner]
box = "learner"
args = ["--learner", "gp"]

[services.arbitrator]
box = "arbitrator"
"""


def thread_cpus(pid: int) -> set[str]:
    """Each thread's CPUs as the kernel holds them."""
    out = set()
    for thread in os.listdir(f"/proc/{pid}/task"):
        with open(f"/proc/{pid}/task/{thread}/status") as f:
            out.add(f.read().split("Cpus_allowed_list:")[1].split()[0])
    return out


def fitting_processes(learner: int) -> list[int]:
    """The learner's children spawned by multiprocessing (its GP's fitter and splitter)."""
    found = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/stat") as f:
                parent = int(f.read().rsplit(")", 1)[1].split()[1])
            with open(f"/proc/{pid}/cmdline") as f:
                spawned = "spawn_main" in f.read()
        except OSError:
            continue
        if parent == learner and spawned:
            found.append(int(pid))
    return found


def test_up_places_the_tick_path_on_its_own_cpus_and_everything_else_off_them(tmp_path):
    placement = plan("auto")
    if placement is None:
        pytest.skip("one CPU: nothing to keep apart")
    tick, rest = {spell(placement.tick)}, {spell(placement.rest)}
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    profile = tmp_path / "placed.toml"
    profile.write_text(PROFILE.format(logs=tmp_path / "logs"))
    sup = dogged("up", str(profile), "--router", endpoint, "--quiet", log=tmp_path / "supervisor.log")
    try:
        rows = wait_until(lambda: (r := ps(endpoint)) and all(x["state"] == "ready" for x in r.values()) and r, 90,
                          "every service ready", poll=0.5)
        assert set(rows) == {"router", "recorder", "platform", "teacher", "learner", "arbitrator"}
        for name, row in rows.items():
            where = tick if row["box"] in TICK_PATH_BOXES else rest
            assert thread_cpus(row["pid"]) == where, (name, row["box"])
            assert {row["cpus"]} == where, (name, row)  # what ps says is what the kernel holds
        assert thread_cpus(sup.pid) == rest, "the supervisor watches from off the tick path"
        fitters = wait_until(lambda: (f := fitting_processes(rows["learner"]["pid"])) and len(f) == 2 and f, 60,
                             "the GP's fitter and splitter")
        for pid in fitters:
            assert thread_cpus(pid) == rest, "a fit is background work"
        if os.path.exists(AUTOGROUP):  # taking of the background CPUs what the others leave (services/priority.py)
            learner = rows["learner"]["pid"]
            assert wait_until(lambda: all(group_nice(f"/proc/{pid}/autogroup") == YIELDING_NICE for pid in fitters),
                              30, "the fitters at the yielding nice")
            assert all(os.getsid(pid) == pid for pid in fitters), "each fitter a session of its own"
            assert group_nice(f"/proc/{learner}/autogroup") == 0, "the learner serves at nice 0"
        text = dogged_ok("ps", endpoint=endpoint).stdout
        line = next(li for li in text.splitlines() if li.startswith("learner"))
        assert f"cpu {spell(placement.tick)}" in line, line
        said = (tmp_path / "supervisor.log").read_text()  # its log goes to its stderr
        assert "the tick path (" in said and f"on CPU {spell(placement.tick)}" in said
    finally:
        dogged_ok("down", endpoint=endpoint)
        sup.wait(60)
