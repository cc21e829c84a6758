"""Hot-swap learners during a 200 Hz run: no tick unanswered, no training pair lost (counted)."""
import json
import os
import signal

import pytest

from rigs.harness import LOOP_SERVICES, Probe, dogged, dogged_ok, free_port
from services.boxes.arbitrator import DEADLINE_MS
from services.waiting import poll
from tests.test_supervisor import ps, wait

pytestmark = pytest.mark.live

# at most 100 s at 200 Hz: the loop is stopped once the swaps are done (a slower machine's swaps outlasted a run
# of 30 s, and the third was asked of a loop that had ended)
TICKS, RATE_HZ = 20_000, 200

PROFILE = """
[profile]
name = "swaptest"
log_dir = "{logs}"

[services.platform]
box = "platform"
args = ["--platform", "point", "--param", "dims=2", "--rate", "{rate}", "--max-ticks", "{ticks}",
        "--summary", "{summary}"]
restart = "never"
""" + LOOP_SERVICES


def test_swap_learners_during_200hz_run(tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    summary = tmp_path / "summary.json"
    profile = tmp_path / "swaptest.toml"
    profile.write_text(PROFILE.format(logs=tmp_path / "logs", ticks=TICKS, rate=RATE_HZ, summary=summary))
    sup = dogged("up", str(profile), "--router", endpoint, "--quiet", log=tmp_path / "supervisor.log")
    probe = Probe(endpoint)
    try:
        wait(lambda: (r := ps(endpoint)) and all(x["state"] == "ready" for x in r.values()), 90, "all ready")
        probe.wait_for(lambda: probe.counter("learner/learner", "pairs") > 300, 90, "the loop running")
        loop_up_tick = probe.counter("platform/platform", "tick")  # every service ready, the loop running
        # another class: the new learner trains on the pairs seen so far
        cross = dogged_ok("swap", "learner", "knn", endpoint=endpoint, timeout=120)
        assert cross.returncode == 0, cross.stdout + cross.stderr
        assert "learner-s1 (knn) serves in place of learner" in cross.stdout
        # the same class with another k: the new learner is the one asked for (k=3, not the snapshot's
        # k=5), taught the old one's history
        same = dogged_ok("swap", "learner", "knn:k=3", endpoint=endpoint, timeout=120)
        assert same.returncode == 0, same.stdout + same.stderr
        assert "learner-s2 (knn:k=3) serves in place of learner-s1, trained on its " in same.stdout, same.stdout
        # the same class and hyper-parameters: the old one's snapshot is restored
        again = dogged_ok("swap", "learner", "knn:k=3", endpoint=endpoint, timeout=120)
        assert again.returncode == 0, again.stdout + again.stderr
        assert "restored from the old one's snapshot" in again.stdout, again.stdout
        assert set(ps(endpoint)) == {"router", "recorder", "platform", "teacher", "learner-s3", "arbitrator"}
        assert not summary.exists(), "every swap was made while the loop ran"
        os.kill(ps(endpoint)["platform"]["pid"], signal.SIGTERM)  # the loop stops; its counts are final
        wait(lambda: summary.exists(), 30, "the platform's summary")
        probe.wait_for_fresh_status("arbitrator/arbitrator")  # its final counters
        published = probe.state("arbitrator/arbitrator", "seq")
        serving = "learner/learner-s3"
        poll(lambda: probe.counter(serving, "pairs") >= published, 15)  # (if never, the asserts below say so)
        counts = json.loads(summary.read_text())
        assert 0 < counts["ticks"] < TICKS
        print(f"unanswered ticks before the loop was up (tick {loop_up_tick}): {counts['unanswered']}, "
              f"the last of them {counts['last_unanswered'][-5:]}")
        # the latest unanswered ticks: past 1,000 start-up misses, the first 1,000 alone would hide a later one; but
        # for those the stop signal cut off, in flight as the platform stopped (a tick waits up to the arbitrator's
        # deadline for its members: at 200 Hz its last 4 ticks, and one more being published)
        in_flight = range(counts["ticks"] - int(DEADLINE_MS / 1000 * RATE_HZ), counts["ticks"] + 1)
        late = [t for t in counts["last_unanswered"] if t >= loop_up_tick]
        assert all(t in in_flight for t in late), counts
        assert probe.counter("arbitrator/arbitrator", "swaps") == 3
        assert published == probe.counter("arbitrator/arbitrator", "train_pairs") > 0.9 * counts["ticks"]
        asked = "learner/learner-s2"  # k=3 asked of a k=5 knn: built as asked, taught the history
        assert probe.state(asked, "params")["k"] == 3, probe.state(asked, "params")
        assert probe.counter(asked, "warmed_by_snapshot", 0) == 0
        assert probe.state(serving, "params")["k"] == 3 and probe.counter(serving, "warmed_by_snapshot") == 1
        assert probe.counter(serving, "warmed") > 300
        assert probe.counter(serving, "seq") == published
        assert probe.counter(serving, "pairs") == published, "every pair reaches the serving learner"
        assert probe.counter(serving, "pairs_lost") == 0
        print(f"{counts['ticks']} ticks all answered; {published} pairs, all in {serving}; "
              f"gap-filled {probe.counter(serving, 'gap_filled')}, duplicates {probe.counter(serving, 'duplicates')}")
    finally:
        probe.close()
        dogged_ok("down", endpoint=endpoint)
        assert sup.wait(60) == 0
