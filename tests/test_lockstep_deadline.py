"""A platform in lockstep says so in its spaces, and the arbitrator waits LOCKSTEP_DEADLINE_MS for a tick's
members unless `--deadline-ms` is given (a 20 ms wait let a briefly stalled learner go unheard while the
simulation raced on without it: CI's red of stop 40, set then per rig, now by the platform's own word)."""
import pytest

from bus_schema import Box, Spaces
from bus_schema.spaces import LOCKSTEP, announced, in_lockstep, paced_like
from rigs.harness import dogged, dogged_ok, free_port
from services.boxes.arbitrator import DEADLINE_MS, LOCKSTEP_DEADLINE_MS, arg_parser, deadline_ms_for
from services.supervisor.verbs import tick_counters
from tests.test_supervisor import ps, wait

SPACES = Spaces(Box.uniform(2, -1.0, 1.0), Box.uniform(1, -1.0, 1.0), {"platform": "point"})


def test_a_platform_at_rate_0_is_announced_in_lockstep_and_at_a_rate_is_not():
    assert in_lockstep(announced(SPACES, 0.0)) and announced(SPACES, 0.0).extra["platform"] == "point"
    assert not in_lockstep(announced(SPACES, 30.0)) and announced(SPACES, 30.0) == SPACES
    assert in_lockstep(Spaces.from_dict(announced(SPACES, 0.0).to_dict()))  # as it crosses the bus
    recorded_in_lockstep = announced(SPACES, 0.0)  # played back at a rate: not in lockstep any more
    assert not in_lockstep(announced(recorded_in_lockstep, 30.0)) and announced(recorded_in_lockstep, 30.0) == SPACES


@pytest.mark.parametrize("said", ["true", 1, "yes", [True], None])
def test_only_a_literal_true_means_lockstep(said):
    assert not in_lockstep(Spaces(SPACES.input, SPACES.output, {LOCKSTEP: said}))


def test_a_box_whose_spaces_derive_from_a_platform_keeps_its_pace():
    perception = Spaces(Box.uniform(4, 0.0, 1.0), SPACES.output, {"perception": "blobs"})
    assert in_lockstep(paced_like(perception, announced(SPACES, 0.0)))
    assert not in_lockstep(paced_like(perception, announced(SPACES, 15.0)))


def test_the_deadline_follows_the_platform_unless_asked():
    assert deadline_ms_for(announced(SPACES, 0.0), None) == LOCKSTEP_DEADLINE_MS > DEADLINE_MS
    assert deadline_ms_for(announced(SPACES, 30.0), None) == DEADLINE_MS
    assert deadline_ms_for(announced(SPACES, 0.0), 35.0) == 35.0
    assert arg_parser().parse_args([]).deadline_ms is None


PROFILE = """
[profile]
name = "lockstep"
log_dir = "{logs}"

[services.platform]
box = "platform"
args = ["--platform", "point", "--param", "dims=2", "--rate", "0", "--sim-hz", "100"]

[services.teacher]
box = "demonstrator"
args = ["--teacher", "sine", "--on"]

[services.learner]
box = "learner"
args = ["--learner", "knn"]

[services.arbitrator]
box = "arbitrator"
"""


@pytest.mark.live
def test_a_lockstep_profile_s_arbitrator_waits_the_lockstep_deadline_and_ps_shows_it(tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    profile = tmp_path / "lockstep.toml"
    profile.write_text(PROFILE.format(logs=tmp_path / "logs"))
    sup = dogged("up", str(profile), "--router", endpoint, "--quiet", log=tmp_path / "supervisor.log")
    try:
        ticks = wait(lambda: (t := ps(endpoint).get("arbitrator", {}).get("ticks", {})).get("deadline_ms") and t,
                     90, "the arbitrator's deadline in ps")
        assert ticks["deadline_ms"] == LOCKSTEP_DEADLINE_MS, ticks
        line = next(s for s in dogged_ok("ps", endpoint=endpoint).stdout.splitlines() if s.startswith("arbitrator"))
        assert f"deadline_ms={LOCKSTEP_DEADLINE_MS:g}" in line, line
    finally:
        down = dogged_ok("down", endpoint=endpoint)
        sup.wait(60)
    assert down.returncode == 0, down.stderr


@pytest.mark.parametrize("said", ["100", float("nan"), float("inf"), True, [100], {"ms": 100}])
def test_ps_shows_a_status_s_deadline_only_when_it_is_a_finite_number(said):
    """(a status's state is free-form: another host's could say anything, and ps formats what it shows)"""
    assert "deadline_ms" not in tick_counters({"state": {"deadline_ms": said}, "counters": {"commands": 3}})
    assert tick_counters({"state": {"deadline_ms": 20.0}})["deadline_ms"] == 20.0
