"""The recorder in a live profile, as real processes: what it records reads back with mcap's own reader
and matches what each publisher counted; replaying the live learner reproduces its answers; a SIGKILL
loses at most the last second; a folder it cannot write leaves the loop running."""
import json
import os
import shutil
import signal
import time
from collections import Counter

import numpy as np
import pytest
from mcap.reader import make_reader

from bus_schema import SchemaError, decode
from bus_schema.catalog import payload_of
from rigs.harness import LOOP_SERVICES, Probe, dogged, dogged_ok, free_port, stop
from services.recording.reader import is_finished, iter_samples, run_files
from services.recording.runs import load_run
from services.replay.replay import as_served, catching_up, replay, schedule
from tests.test_supervisor import ps, wait

pytestmark = pytest.mark.live

PROFILE = """
[profile]
name = "rectest"
log_dir = "{tmp}/logs"
record_dir = "{record_dir}"

[services.platform]
box = "platform"
args = ["--platform", "point", "--param", "dims=2", "--rate", "100", "--max-ticks", "{ticks}",
        "--summary", "{tmp}/summary.json"]
restart = "never"
after = [{after}]
""" + LOOP_SERVICES


def up(tmp_path, ticks=100_000, record_dir=None, after='"recorder"'):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    profile = tmp_path / "rectest.toml"
    profile.write_text(PROFILE.format(tmp=tmp_path, ticks=ticks, record_dir=record_dir or tmp_path / "rec",
                                      after=after))
    sup = dogged("up", str(profile), "--router", endpoint, "--quiet", log=tmp_path / "supervisor.log")
    return endpoint, sup


def last_status(run, member: str) -> dict:
    role, name = member.split("/")
    found = [s.decoded() for s in iter_samples(run, {f"dl/main/status/{role}/{name}"})]
    assert found, f"no status of {member} recorded"
    return found[-1].counters


def recording_for(folder) -> float:
    """How many seconds ago the first sample in the recorder's one file (in progress) was logged; 0 if none."""
    runs = list(folder.iterdir()) if folder.is_dir() else []
    if len(runs) != 1 or not list(runs[0].glob("*.mcap")):
        return 0.0
    first = next(iter_samples(runs[0], truncated=[]), None)
    return (time.time_ns() - first.log_ns) / 1e9 if first else 0.0


def test_a_recorded_run_reads_back_counts_match_and_replay_reproduces_the_learner(tmp_path):
    endpoint, sup = up(tmp_path)
    probe = Probe(endpoint)
    try:
        wait(lambda: (r := ps(endpoint)) and all(x["state"] == "ready" for x in r.values()), 90, "all ready")
        probe.wait_for(lambda: probe.counter("learner/learner", "learned") >= 400, 60, "400 pairs learned")
        off = dogged_ok("teach", "off", endpoint=endpoint)  # the student drives the rest
        assert off.returncode == 0, off.stdout + off.stderr
        probe.wait_for(lambda: probe.counter("arbitrator/arbitrator", "mode_student") >= 300, 60, "the student driving")
        os.kill(ps(endpoint)["platform"]["pid"], signal.SIGTERM)  # the loop stops; its counts are final
        wait(lambda: (tmp_path / "summary.json").exists(), 30, "the platform's summary")
        # every service's final counters out, and recorded
        probe.wait_for_fresh_status("arbitrator/arbitrator", "learner/learner", "teacher/teacher")
        assert dogged_ok("down", endpoint=endpoint).returncode == 0
        assert sup.wait(30) == 0
    finally:
        probe.close()
        stop(sup)
    [run] = list((tmp_path / "rec").iterdir())
    [path] = run_files(run)
    assert is_finished(path)
    counts = Counter()
    with open(path, "rb") as f:  # mcap's own reader; every message decodes with the bus schema
        for schema, channel, message in make_reader(f).iter_messages():
            cls, _ = payload_of(channel.topic)
            assert schema.name == f"dogged.{cls.__name__}" and channel.message_encoding == "msgpack"
            try:
                decode(cls, message.data, channel.topic)
            except SchemaError as err:
                raise AssertionError(f"a recorded message does not decode: {err}") from None
            counts[channel.topic] += 1
    summary = json.loads((tmp_path / "summary.json").read_text())
    arbitrator, learner = last_status(run, "arbitrator/arbitrator"), last_status(run, "learner/learner")
    teacher = last_status(run, "teacher/teacher")
    assert counts["dl/main/input"] == summary["ticks"] > 700
    assert counts["dl/main/applied"] == summary["applied"]
    assert counts["dl/main/command"] == arbitrator["commands"]
    assert counts["dl/main/proposal/learner/learner"] == learner["proposals"]
    assert counts["dl/main/proposal/teacher/teacher"] == teacher["proposals"]
    assert counts["dl/main/teach"] == 1
    seqs = [s.decoded().seq for s in iter_samples(run, {"dl/main/train"})]
    assert seqs == list(range(1, arbitrator["train_pairs"] + 1)) and len(seqs) > 100  # lossless: every pair

    recorded = load_run(run)
    live = recorded.live["learner"]
    # the learner answers from its first answer on (it starts once its kernels are compiled: tick 34 to 133 seen)
    assert len(live.ticks) >= 0.95 * (recorded.ticks[-1] - live.ticks[0] + 1) and len(live.ticks) > 300
    assert (recorded.modes == "student").sum() >= 300
    # (the ticks it answered while it caught up, unsure as the service answers them: a learner started late
    # on a slow machine had 114 pairs to learn and answered 3 ticks so, which the model alone answered sure)
    unsure = catching_up(recorded, "learner")
    result = as_served(replay(recorded, "lwpr", seed=0, plan=schedule(recorded, "learner")), unsure)
    inputs, answers = recorded.answered("learner")
    assert len(answers) == len(live.ticks)  # (no recorder restart here: every answered input recorded)
    assert np.max(np.abs(result.y[inputs] - live.y[answers])) <= 1e-9
    assert np.max(np.abs(result.confidence[inputs] - live.confidence[answers])) <= 1e-9
    other = replay(recorded, "lwpr:init_D=2", seed=0, plan=schedule(recorded, "learner"))
    assert np.max(np.abs(other.y[inputs] - live.y[answers])) > 1e-3  # the check can tell learners apart


def test_a_sigkilled_recorder_loses_at_most_its_last_second_and_comes_back(tmp_path):
    endpoint, sup = up(tmp_path, ticks=100_000)
    probe = Probe(endpoint)
    try:
        wait(lambda: (r := ps(endpoint)) and all(x["state"] == "ready" for x in r.values()), 90, "all ready")
        wait(lambda: recording_for(tmp_path / "rec") > 2.0, 30, "the recorder's file holding 2 s of the run")
        pid = ps(endpoint)["recorder"]["pid"]
        [run] = list((tmp_path / "rec").iterdir())
        [path] = run_files(run)
        os.kill(pid, signal.SIGKILL)
        killed_ns = time.time_ns()
        left = tmp_path / "left" / path.name
        left.parent.mkdir()
        shutil.copy(path, left)  # as the kill left it, before the restarted recorder repairs it
        tick_at_kill = probe.counter("platform/platform", "tick")
        wait(lambda: (r := ps(endpoint)) and r["recorder"]["pid"] != pid and r["recorder"]["state"] == "ready",
             30, "the recorder restarted")
        wait(lambda: len(run_files(run)) == 2, 10, "a second file")
        probe.wait_for(lambda: probe.counter("platform/platform", "tick") > tick_at_kill + 300, 30, "the loop going on")
    finally:
        probe.close()
        stop(sup)
    assert not is_finished(left)
    truncated = []
    last_ns = max(s.log_ns for s in iter_samples(left, truncated=truncated))
    lost_s = (killed_ns - last_ns) / 1e9
    assert lost_s <= 1.0, f"the kill lost the last {lost_s:.2f} s"
    assert is_finished(path)  # repaired by the restarted recorder, and mcap's seeking reader opens it
    with open(path, "rb") as f:
        assert make_reader(f).get_summary().statistics.message_count >= sum(1 for _ in iter_samples(left))
    second = run_files(run)[1]
    assert second.name.startswith("recorder-0001-")


def test_a_folder_the_recorder_cannot_write_is_a_clear_error_and_the_loop_runs_on(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")  # (root writes anywhere; nobody makes a folder inside a file)
    endpoint, sup = up(tmp_path, ticks=100_000, record_dir=blocker / "rec", after="")
    probe = Probe(endpoint)
    try:
        wait(lambda: (r := ps(endpoint)) and all(x["state"] == "ready" for x in r.values()), 90, "all ready")
        probe.wait_for(lambda: probe.counter("learner/learner", "learned") > 200, 60, "the loop learning")
        why = wait(lambda: ps(endpoint)["recorder"].get("why"), 10, "the recorder's error in ps")
        assert "cannot write" in why and "Not a directory" in why, why
        printed = dogged_ok("ps", endpoint=endpoint).stdout
        assert "cannot write" in printed, printed
        assert probe.counter("recorder/recorder", "not_recorded") > 0
        assert ps(endpoint)["recorder"]["state"] == "ready" and ps(endpoint)["recorder"]["restarts"] == 0
    finally:
        probe.close()
        stop(sup)
    assert "cannot write" in (tmp_path / "logs" / "recorder.log").read_text()
