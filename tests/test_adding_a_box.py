"""The box docs/adding-a-box.md shows (docs/examples/middle.py): under 40 lines, shown there as it is,
and run for real over a router beside a platform and an arbitrator, Figure 1's default controller: every
command is its proposal, the middle of the output space, while nobody teaches or learns."""
import re
import subprocess
import sys

import numpy as np

from bus_schema import Command, Input, decode, encode
from rigs.harness import REPO, Probe, dogged, stop

EXAMPLE = REPO / "docs" / "examples" / "middle.py"


def test_the_example_box_is_under_40_lines_and_the_page_shows_it_as_it_is():
    text = EXAMPLE.read_text()
    assert len(text.splitlines()) < 40
    [shown] = re.findall(r"```python\n(.*?)```", (REPO / "docs" / "adding-a-box.md").read_text(), re.S)
    assert shown == text


def test_the_example_box_runs_as_the_default_controller(router, tmp_path):
    c = ["--connect", router]
    procs = [dogged("run", "platform", "--param", "dims=2", "--rate", "50", *c, log=tmp_path / "platform.log"),
             dogged("run", "arbitrator", *c, log=tmp_path / "arbitrator.log")]
    with open(tmp_path / "middle.log", "ab") as log:
        procs.append(subprocess.Popen([sys.executable, str(EXAMPLE), *c], cwd=REPO, stdout=log,
                                      stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL))
    probe = Probe(router)
    try:
        commands = probe.record("dl/main/command")
        probe.wait_for(lambda: probe.counter("default/middle", "proposals") >= 100, 60, "100 proposals")
        decided = [decode(Command, raw, key, {"y": 2}) for key, raw, _ in commands][-50:]
        assert len(decided) == 50
        assert all(cmd.source == "default/middle" and cmd.mode == "unsure" for cmd in decided)
        assert all(np.array_equal(cmd.y, [0.0, 0.0]) for cmd in decided)
        assert probe.counter("default/middle", "rejected") == 0
        probe.put("dl/main/input", encode(Input(1, 0.0, np.zeros(3))))  # 3 inputs, not the platform's 4
        probe.wait_for(lambda: probe.counter("default/middle", "rejected") == 1, 10, "the malformed input rejected")
        assert probe.state("default/middle", "host") and probe.counter("default/middle", "inbox_dropped") == 0
    finally:
        probe.close()
        assert stop(*procs) == [0, 0, 0]
