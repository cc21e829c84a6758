"""Swap the learner, stop the profile, start it again: the learner starts from what the swapped-in learner
knew (its log), not from the log of the learner the swap retired (services/supervisor/pair_logs.py), and
learns it between answers (services/boxes/learner.py)."""
import msgpack
import numpy as np
import pytest

from bus_schema import TrainingPair
from rigs.harness import LOOP_SERVICES, Probe, dogged, dogged_ok, free_port
from services.pairlog import PairLog
from tests.test_supervisor import ps, wait

pytestmark = pytest.mark.live

# a point at 100 Hz, its learners' state kept; {name} and the services after it are each test's
HEAD = """
[profile]
name = "{name}"
log_dir = "{logs}"
state_dir = "{state}"

[services.platform]
box = "platform"
args = ["--platform", "point", "--param", "dims=2", "--rate", "100"]
"""
PROFILE = HEAD.replace("{name}", "swapup") + LOOP_SERVICES


def records(path) -> int:
    unpacker = msgpack.Unpacker(raw=False)
    unpacker.feed(path.read_bytes())
    return sum(1 for _ in unpacker)


def up(tmp_path, endpoint, profile):
    return dogged("up", str(profile), "--router", endpoint, "--quiet", log=tmp_path / "supervisor.log")


def all_ready(endpoint):
    wait(lambda: (r := ps(endpoint)) and "learner" in r and all(x["state"] == "ready" for x in r.values()), 90,
         "all ready")


def down(sup, endpoint):
    dogged_ok("down", endpoint=endpoint)
    assert sup.wait(60) == 0


def test_the_next_up_starts_from_the_swapped_in_learners_pairs(tmp_path):
    endpoint, state = f"tcp/127.0.0.1:{free_port()}", tmp_path / "state"
    profile = tmp_path / "swapup.toml"
    profile.write_text(PROFILE.format(logs=tmp_path / "logs", state=state))
    sup, probe = up(tmp_path, endpoint, profile), None
    try:
        all_ready(endpoint)
        probe = Probe(endpoint)
        probe.wait_for(lambda: probe.counter("learner/learner", "pairs") > 200, 60, "pairs taught")
        swap = dogged_ok("swap", "learner", "knn", endpoint=endpoint, timeout=120)
        assert "learner-s1 (knn) serves in place of learner" in swap.stdout, swap.stdout + swap.stderr
        warmed = probe.counter("learner/learner-s1", "warmed")
        probe.wait_for(lambda: probe.counter("learner/learner-s1", "pairs") > warmed + 200, 60, "pairs after the swap")
    finally:
        if probe:
            probe.close()
        down(sup, endpoint)
    retired, served = records(state / "learner.pairs"), records(state / "learner-s1.pairs")
    assert served > retired, (retired, served)  # the retired one learned until it was retired, not after

    sup, probe = up(tmp_path, endpoint, profile), None
    try:
        all_ready(endpoint)
        probe = Probe(endpoint)
        probe.wait_for(lambda: probe.counter("learner/learner", "replayed", -1) >= 0, 30, "the learner's status")
        assert probe.counter("learner/learner", "replayed") == served
        probe.wait_for(lambda: probe.counter("learner/learner", "backlog", -1) == 0, 60, "the learner caught up")
    finally:
        if probe:
            probe.close()
        down(sup, endpoint)
    [aside] = state.glob("learner.pairs.*.earlier")
    assert records(aside) == retired and not (state / "learner-s1.pairs").exists()
    assert "replaying" in (tmp_path / "logs" / "learner.log").read_text()


LONG_LOG = HEAD.replace("{name}", "longlog") + """
[services.learner]
box = "learner"
args = ["--learner", "gp"]
ready_timeout_s = 20

[services.arbitrator]
box = "arbitrator"
"""


def test_a_learner_with_a_log_longer_to_learn_than_its_ready_timeout_serves_at_once(tmp_path):
    """(issue 31) It learned its whole log before declaring itself ready: 40,000 pairs take a GP longer than
    its 20 s ready timeout, so it was stopped and restarted until its supervisor gave up."""
    endpoint, state = f"tcp/127.0.0.1:{free_port()}", tmp_path / "state"
    log = PairLog(4, 2, state / "learner.pairs")
    log.replay_file()
    rng = np.random.default_rng(0)
    for seq, x in enumerate(rng.uniform(-1, 1, (40_000, 4)), start=1):
        log.append(TrainingPair("earlier", seq, seq, x, np.sin(3 * x[:2]), "teacher/t"))
    log.close()
    profile = tmp_path / "longlog.toml"
    profile.write_text(LONG_LOG.format(logs=tmp_path / "logs", state=state))
    sup, probe = up(tmp_path, endpoint, profile), None
    try:
        all_ready(endpoint)
        probe = Probe(endpoint)
        probe.wait_for(lambda: probe.counter("learner/learner", "replayed", -1) >= 0, 30, "the learner's status")
        assert probe.counter("learner/learner", "replayed") == 40_000
        assert probe.counter("learner/learner", "backlog") > 0, "it serves while it learns its log"
        assert ps(endpoint)["learner"]["restarts"] == 0
    finally:
        if probe:
            probe.close()
        down(sup, endpoint)
