"""What the soak's hour took for an fd leak (issue 31): in mirroring's hour every process held two more fds
for the minutes a swap's new learner caught up beside the old one, and a learner retired then ended two
higher than it began. A Zenoh peer holds two sockets for every other peer while that peer lives; these
check, as real processes, that a service's fds come back to what they were each time a peer leaves, killed
or stopped, so that a peer coming and going leaks nothing. And the soak's figures fit fds only over samples
with the bus's usual members (rigs/soak/figures.py)."""
import os
import subprocess
import sys
from types import SimpleNamespace

import pytest

from rigs.harness import REPO, dogged, stop, wait_until
from rigs.soak.figures import growth

JOINS = 4
PEER = ("import services, sys, time, zenoh; from services.bus.config import zenoh_config\n"
        "with zenoh.open(zenoh_config(connect=[sys.argv[1]])):\n    time.sleep(600)")


def fds(proc) -> int:
    return len(os.listdir(f"/proc/{proc.pid}/fd"))


def steady(proc, seconds: float = 1.0) -> int:
    """Its fd count once unchanged for `seconds` (sampled every 0.1 s)."""
    seen = []

    def settled():
        seen.append(fds(proc))
        return len(seen) > seconds / 0.1 and len(set(seen[-int(seconds / 0.1):])) == 1 and seen[-1]
    return wait_until(settled, 30, "a steady count of fds", poll=0.1)


@pytest.mark.live
def test_a_services_fds_come_back_each_time_a_peer_leaves(router, tmp_path):
    recorder = dogged("run", "recorder", "--out", str(tmp_path / "rec"), "--connect", router,
                      log=tmp_path / "recorder.log")
    try:
        wait_until(lambda: any((tmp_path / "rec").glob("*.mcap")), 60, "the recorder's first file")
        before = steady(recorder)
        for join in range(JOINS):
            peer = subprocess.Popen([sys.executable, "-c", PEER, router], cwd=REPO, stdin=subprocess.DEVNULL,
                                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            joined = wait_until(lambda: fds(recorder) > before and fds(recorder), 30,
                                f"the recorder's link to peer {join} (its fds past {before})")
            (peer.kill if join % 2 else peer.terminate)()
            peer.wait(10)
            wait_until(lambda: fds(recorder) == before, 30,
                       f"the recorder's fds back to {before} after peer {join} left (had {joined})")
            print(f"peer {join}: {before} -> {joined} -> {fds(recorder)}")
        assert steady(recorder) == before
    finally:
        assert stop(recorder) == [0]


def row(t, **fds_by_name):
    return SimpleNamespace(t=t, procs={n: SimpleNamespace(pid=1 if n == "old" else 2, rss_mb=50.0, fds=f)
                                       for n, f in fds_by_name.items()})


def test_the_fds_are_fitted_over_samples_with_the_usual_members():
    # minutes 0-9 one learner ("old"); 10-13 a new one catching up beside it (every process two more fds);
    # then the new one alone
    rows = [row(60 * k, old=36, a=30) for k in range(10)]
    rows += [row(60 * k, old=38, new=38, a=32) for k in range(10, 14)]
    rows += [row(60 * k, new=36, a=30) for k in range(14, 30)]
    found = {g.service: g for g in growth(rows, warmup_s=120)}
    assert found["a"].fds_per_hour == 0.0 and found["a"].fds == (30, 30) and found["a"].fd_points == 24
    assert found["new"].fds_per_hour == 0.0
    assert found["old"].fds_per_hour == 0.0 and found["old"].fd_points == 8
    # a process whose fds grow while the members are as usual is fitted (2 a minute: 120 an hour)
    leaking = [row(60 * k, old=36 + 2 * k, a=30) for k in range(10)]
    assert growth(leaking, warmup_s=0)[0].fds_per_hour == pytest.approx(120.0)
