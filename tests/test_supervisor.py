"""`dogged up` brings up real processes; a learner killed with SIGKILL comes back; `dogged down` leaves none."""
import json
import os
import signal
import time

import pytest

from services.boxes.arbitrator import DEADLINE_MS
from rigs.harness import REPO, Probe, dogged, dogged_ok, free_port, wait_until

pytestmark = pytest.mark.live

PROFILE = """
[profile]
name = "suptest"
log_dir = "{logs}"

[services.platform]
box = "platform"
args = ["--platform", "point", "--param", "dims=2", "--rate", "100"]

[services.teacher]
box = "demonstrator"
args = ["--teacher", "sine", "--on"]

[services.learner]
box = "learner"
args = ["--learner", "knn"]  # its state: the profile's default state_dir (beside log_dir)
restart = "always"
backoff_s = 0.2

[services.arbitrator]
box = "arbitrator"
"""


def ps(endpoint):
    result = dogged_ok("ps", "--json", endpoint=endpoint)
    return {row["name"]: row for row in json.loads(result.stdout)["services"]} if result.returncode == 0 else {}


def alive(pid):
    try:
        os.kill(pid, 0)
        return True
    except ProcessLookupError:
        return False


def wait(condition, timeout, what):
    return wait_until(condition, timeout, what, poll=0.2)


def test_up_ps_sigkill_restart_down(tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    profile = tmp_path / "suptest.toml"
    profile.write_text(PROFILE.format(logs=tmp_path / "logs", state=tmp_path / "state"))
    sup = dogged("up", str(profile), "--router", endpoint, "--quiet", log=tmp_path / "supervisor.log")
    probe = None
    try:
        rows = wait(lambda: (r := ps(endpoint)) and all(x["state"] == "ready" for x in r.values()) and r,
                    90, "every service ready")
        assert set(rows) == {"router", "recorder", "platform", "teacher", "learner", "arbitrator"}
        pids = {name: row["pid"] for name, row in rows.items()}
        assert len(set(pids.values())) == 6 and all(alive(p) for p in pids.values())
        text = dogged_ok("ps", endpoint=endpoint).stdout
        assert "learner" in text and "ready" in text

        probe = Probe(endpoint)
        probe.wait_for(lambda: probe.counter("learner/learner", "pairs") > 100, 30, "100 pairs learned")
        os.kill(pids["learner"], signal.SIGKILL)
        row = wait(lambda: (r := ps(endpoint).get("learner")) and r["restarts"] == 1 and r["state"] == "ready" and r,
                   60, "the learner restarted")
        assert row["pid"] != pids["learner"] and alive(row["pid"])
        # the restarted learner replayed its pair log and serves the loop again
        probe.wait_for(lambda: probe.counter("learner/learner", "replayed") > 100, 30, "the pair log replayed")
        before = probe.counter("learner/learner", "proposals")
        probe.wait_for(lambda: probe.counter("learner/learner", "proposals") > before + 100, 30, "proposals again")
        assert probe.counter("learner/learner", "pairs_lost") == 0
        # while the learner was down the arbitrator decided without it: ps says how many ticks, and their share
        ticks = wait(lambda: (t := ps(endpoint)["arbitrator"].get("ticks", {})).get("without_learner") and t, 10,
                     "the ticks without the learner in ps")
        assert 0 < ticks["without_learner_pct"] < 100, ticks
        assert ticks["deadline_ms"] == DEADLINE_MS, ticks  # the platform ticks at 100 Hz: not in lockstep
        arbitrator_line = next(line for line in dogged_ok("ps", endpoint=endpoint).stdout.splitlines()
                               if line.startswith("arbitrator"))
        assert "without_learner=" in arbitrator_line and "without_learner_pct=" in arbitrator_line, arbitrator_line

        logs = dogged_ok("logs", "learner", "-n", "400", endpoint=endpoint)
        assert "exited with -9" in logs.stdout and "replaying" in logs.stdout
    finally:
        if probe:
            probe.close()
        down = dogged_ok("down", endpoint=endpoint)
        code = sup.wait(60)
    assert down.returncode == 0, down.stderr
    assert code == 0
    time.sleep(0.5)
    leftovers = [name for name, pid in pids.items() if alive(pid)]
    assert leftovers == [], f"orphans: {leftovers}"


def test_a_service_that_will_not_stop_says_where_it_is_stuck_before_it_is_killed(tmp_path):
    """StopFlag registers a stack dump on SIGUSR1; the supervisor (and the test harness) send it to a
    service that ignores SIGTERM for too long, so its log shows the stuck line, then kill it."""
    import subprocess
    import sys

    from services.supervisor.process import dump_stacks_then_kill

    stuck = tmp_path / "stuck.py"
    stuck.write_text("import threading\nfrom services.bus.lifecycle import StopFlag\nstop = StopFlag()\n"
                     "lock = threading.Lock()\nlock.acquire()\nprint('ready', flush=True)\n"
                     "lock.acquire()  # never returns: nothing looks at the stop flag\n")
    proc = subprocess.Popen([sys.executable, str(stuck)], cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    assert proc.stdout.readline().strip() == "ready"
    proc.terminate()
    with pytest.raises(subprocess.TimeoutExpired):
        proc.wait(1.0)
    assert dump_stacks_then_kill(proc) == -9
    assert f'File "{stuck}", line 7' in proc.stdout.read()



def test_a_service_killed_at_its_stop_is_marked_so_the_supervisor_says_so(tmp_path):
    """`dogged down` ends with a warning naming a service that took a SIGKILL: what it had not written
    (a recording's index, a summary) may be missing, and the run's log says where to look."""
    import sys

    from services.supervisor.process import ManagedProcess
    from services.supervisor.profile import ServiceSpec

    stuck, quits = tmp_path / "stuck.py", tmp_path / "quits.py"
    stuck.write_text("import signal, time\nsignal.signal(signal.SIGTERM, signal.SIG_IGN)\nprint('ready', flush=True)\n"
                     "time.sleep(60)\n")
    quits.write_text("import time\nprint('ready', flush=True)\ntime.sleep(60)\n")
    procs = {name: ManagedProcess(ServiceSpec(name, "platform", "main"), [sys.executable, str(path)], tmp_path,
                                  echo=False) for name, path in (("stuck", stuck), ("quits", quits))}
    for proc in procs.values():
        proc.start()
    for proc in procs.values():
        wait(lambda p=proc: "ready" in p.log_path.read_text(), 20, f"{proc.spec.name} started")
        proc.stop(timeout=1.0)
    assert procs["stuck"].killed
    assert not procs["quits"].killed
    assert "did not stop within 1 s" in procs["stuck"].log_path.read_text()

SMALL = PROFILE.split("\n[services.learner]")[0]  # its platform and teacher only


def test_services_stop_when_the_supervisor_is_killed(tmp_path):
    """SIGKILL gives the supervisor no chance to stop anything: each service (the router too) sees its
    parent gone and stops by itself."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    profile = tmp_path / "orphans.toml"
    profile.write_text(SMALL.format(logs=tmp_path / "logs"))
    sup = dogged("up", str(profile), "--router", endpoint, "--quiet", log=tmp_path / "supervisor.log")
    try:
        rows = wait(lambda: (r := ps(endpoint)) and len(r) == 4 and all(x["state"] == "ready" for x in r.values())
                    and r, 90, "every service ready")
        pids = {name: row["pid"] for name, row in rows.items()}
        assert all(alive(p) for p in pids.values())
    finally:
        sup.send_signal(signal.SIGKILL)
        sup.wait(10)
    try:
        wait(lambda: not any(alive(p) for p in pids.values()), 10, "every service gone after its supervisor")
    finally:  # a failed check leaves no orphans behind
        for pid in filter(alive, pids.values()):
            os.kill(pid, signal.SIGKILL)
