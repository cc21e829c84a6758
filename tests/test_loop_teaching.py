"""A teacher is switched on, then off, and the student reproduces the taught mapping (real processes)."""
import subprocess
import sys

import numpy as np
import pytest

from bus_schema import Command, Input, decode
from rigs.harness import REPO, Probe, dogged, dogged_ok, stop


def sine_teacher(x):  # services.teachers.functions.SineTeacher with its defaults, dims=2
    return 0.8 * np.sin(1.5 * x[[1, 0]])


@pytest.mark.parametrize("learner", ["lwpr", "knn"])
def test_teach_on_then_off_student_reproduces(router, tmp_path, learner):
    connect = ["--connect", router]
    procs = [dogged("run", "platform", "--platform", "point", "--param", "dims=2", "--param", "wander_hz=2.0",
                    "--rate", "100", *connect, log=tmp_path / "platform.log"),
             dogged("run", "demonstrator", "--teacher", "sine", "--param", "frequency=1.5", *connect,
                    log=tmp_path / "teacher.log"),
             dogged("run", "learner", "--learner", learner, *connect, log=tmp_path / "learner.log"),
             dogged("run", "arbitrator", *connect, log=tmp_path / "arbitrator.log")]
    probe = Probe(router)
    try:
        probe.wait_for(lambda: probe.counter("arbitrator/arbitrator", "commands") > 50, 60, "the loop to run")
        unsure = probe.counter("arbitrator/arbitrator", "mode_unsure")
        assert unsure > 0, "an untaught student must say it is unsure"
        result = dogged_ok("teach", "on", "--teacher", "sine", endpoint=router)
        assert result.returncode == 0, result.stderr
        assert "teaching on" in result.stdout
        probe.wait_for(lambda: probe.counter("arbitrator/arbitrator", "train_pairs") >= 2000, 60, "2000 pairs (20 s)")
        assert dogged_ok("teach", "off", endpoint=router).returncode == 0
        inputs, commands, pairs = (probe.record(f"dl/main/{k}") for k in ("input", "command", "train"))
        probe.wait_for(lambda: len(commands) >= 400, 30, "400 commands after teaching")
        assert pairs == [], "the teacher is off: no training pair may follow"
        taught = probe.counter("arbitrator/arbitrator", "train_pairs")
        xs = {m.tick: m.x for m in (decode(Input, raw, k, {"x": 4}) for k, raw, _ in inputs)}
        cmds = [decode(Command, raw, k, {"y": 2}) for k, raw, _ in commands]
        judged = [(c, xs[c.tick]) for c in cmds[50:] if c.tick in xs]
        assert len(judged) >= 300
        student = [c for c, _ in judged if c.mode == "student"]
        assert len(student) >= 0.9 * len(judged), f"{len(student)} of {len(judged)} ticks in student mode"
        errors = np.array([c.y - sine_teacher(x) for c, x in judged])
        rms = float(np.sqrt(np.mean(errors ** 2)))
        print(f"{learner}: {taught} pairs taught, student RMS error {rms:.4f} over {len(judged)} ticks")
        assert rms < 0.1
    finally:
        probe.close()
        assert stop(*procs) == [0, 0, 0, 0]


def first_tick_line(watcher: subprocess.Popen) -> str:
    """What `dogged watch` printed up to and with its first line about a command (its first mode)."""
    seen = []
    for line in watcher.stdout:
        seen.append(line)
        if "tick" in line:
            return "".join(seen)
    raise AssertionError(f"dogged watch ended having printed only {''.join(seen)!r}")


def test_watch_shows_the_robots_mode_as_a_person_switches_teaching(router, tmp_path):
    """`dogged watch` is the robot's ears in a terminal: untaught it asks (green), taught it is
    red, and each change is one line; a malformed command is rejected, not shown."""
    connect = ["--connect", router]
    procs = [dogged("run", "platform", "--platform", "point", "--param", "dims=2", "--rate", "100", *connect,
                    log=tmp_path / "platform.log"),
             dogged("run", "demonstrator", "--teacher", "sine", *connect, log=tmp_path / "teacher.log"),
             dogged("run", "learner", "--learner", "lwpr", *connect, log=tmp_path / "learner.log"),
             dogged("run", "arbitrator", *connect, log=tmp_path / "arbitrator.log")]
    probe = Probe(router)
    watcher = None
    try:
        probe.wait_for(lambda: probe.counter("arbitrator/arbitrator", "commands") > 50, 60, "the loop to run")
        watcher = subprocess.Popen([sys.executable, "-m", "services.cli", "--connect", router, "watch", "--seconds",
                                    "8"],
                                   cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        first = first_tick_line(watcher)  # subscribed, and it has shown the robot's mode
        probe.put("dl/main/command", b"\x81\xa1v\x01")  # a map with a version and nothing else
        assert dogged_ok("teach", "on", endpoint=router).returncode == 0
        out = first + watcher.stdout.read()  # (the rest of its 8 s; read from the same buffer as the first)
        err = watcher.stderr.read()
        watcher.wait(30)
    finally:
        probe.close()
        assert stop(*procs) == [0, 0, 0, 0]
    lines = [line for line in out.splitlines() if "tick" in line]
    print(out, err)
    assert watcher.returncode == 0
    assert lines[0].split()[3] == "GREEN" and "asks to be taught" in lines[0]
    assert any(line.split()[3] == "RED" and "teacher/" in line for line in lines[1:])
    assert "1 malformed commands rejected" in err
