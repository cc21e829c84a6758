"""The soak's quick run (issue 31): `benchmarks/soak.py --quick`, a minute of each deploy profile under the
scripted day (two teachers, swaps, SIGKILLs, the page, a stranger, a full disk), as a process of its own.
What must hold whatever the machine's load (its timings are the benchmark's to report, not asserted here):
no pair lost, every recording opens and replays, every killed service back, the stranger refused, the
recorder recording again after its disk was full, and no process growing without bound."""
import json
import subprocess
import sys

import pytest

from rigs.harness import REPO

pytestmark = pytest.mark.live  # the soak is a process of its own, with the profiles' processes

RSS_MB_BOUND = 2000.0  # a service with its spawned processes (the GP's fits: ~550 MB), with room to spare
GREW_MB_BOUND = 300.0  # in its minute, after its first fifth (a GP warming: ~100 MB)
FDS_GREW_BOUND = 100
PROFILES = ("mirroring", "ballseek")


@pytest.fixture(scope="module")
def soak(tmp_path_factory) -> dict:
    """Each profile's quick soak, the two side by side, each a process of its own (`benchmarks/soak.py --quick
    --profile <name>`): one after the other, as `benchmarks/soak.py --quick` runs them, they took 230 s of CI's
    30 minutes. Each profile's last line, by name."""
    out = tmp_path_factory.mktemp("soak")
    procs, lines = {}, {}
    try:
        for name in PROFILES:
            with open(out / f"{name}.out", "w") as said, open(out / f"{name}.err", "w") as err:  # (not pipes: one
                procs[name] = subprocess.Popen(  # would fill while the other is waited for)
                    [sys.executable, "benchmarks/soak.py", "--quick", "--profile", name, "--out", str(out / name)],
                    cwd=REPO, stdout=said, stderr=err)
        for name, proc in procs.items():
            code = proc.wait(timeout=1200)
            said, err = (out / f"{name}.out").read_text(), (out / f"{name}.err").read_text()
            print(said[-6000:], err[-4000:])
            assert code == 0, err[-4000:]
            lines[name] = json.loads(said.strip().splitlines()[-1])
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                proc.terminate()  # the soak stops every profile and unmounts its disk (as at Ctrl-C)
                proc.wait(60)
    return lines


@pytest.fixture(scope="module", params=PROFILES)
def profile(request, soak):
    return soak[request.param]["profiles"][request.param]


def test_no_pair_is_lost(profile):
    assert profile["pairs_lost"] == 0
    assert profile["pairs_taught"] > 100
    assert profile["pairs_held"] == profile["pairs_in_log"] == profile["pairs_in_memory"] == profile["pairs_taught"]


def test_every_recording_opens_and_replays_even_those_a_full_disk_cut(profile):
    assert profile["recordings"] >= 2 and profile["recordings_all_open"], \
        (profile["recordings_not_open"], profile["run_replay_said"])
    assert profile["disk_fills"] == 0 or profile["recording_again_after_fill"]


def test_every_killed_service_comes_back(profile):
    assert {"router", "recorder"} <= set(profile["kills"])
    assert profile["kills_not_back"] == [] and profile["teachers_back_switched_wrong"] == [], profile
    for service in set(profile["kills"]) & set(profile["restarts"]):
        assert profile["restarts"][service] >= profile["kills"].count(service), (service, profile["restarts"])


def test_the_page_left_open_is_online_at_the_end(profile):
    assert profile["page"].get("link") in (None, "online")  # (None: no chromium here, no page)


def test_the_stranger_gets_nothing(profile):
    assert profile["bursts"] >= 1
    assert profile["burst_got_through"] == 0 and profile["burst_refused"] >= profile["bursts"]


def test_no_process_grows_without_bound(profile):
    assert profile["rss_mb_max"] < RSS_MB_BOUND
    assert profile["rss_grew_mb_max"] < GREW_MB_BOUND and profile["fds_grew_max"] < FDS_GREW_BOUND, profile


def test_the_student_is_judged_beside_what_its_teaching_alone_makes_of_it(profile):
    """(rigs/soak/taught.py: the wired learner trained offline on the recorded pairs, on the last span's inputs)"""
    assert profile["student_error_last"] is not None
    assert profile["student_error_taught_reference"] is not None and profile["student_error_taught_reference"] >= 0
    program = profile["student_error_program_reference"]  # the person's pairs left out
    assert program is not None and program >= 0
    split = profile["student_last_span"]  # the learner's answers drove the last span, bar deadline misses
    assert split["answered"] > 0 and split["error_answered"] is not None, split
