"""Labs built at the same moment take different nets (rigs/netlab/lab.claim_net): two soaks side by side chose
the same 10.<net> from the routes alone, before either had routed it."""
import subprocess
import sys

import pytest

from rigs.harness import REPO
from rigs.netlab.lab import available, claim_net

pytestmark = [pytest.mark.live, pytest.mark.skipif(bool(available()), reason=available() or "")]

HOLD = ("import sys; from rigs.netlab.lab import claim_net; net = claim_net(); print(net[0], flush=True); "
        "sys.stdin.read()")  # holds its claim until told to end


def test_a_net_held_by_another_process_is_not_chosen_and_is_free_again_once_let_go():
    other = subprocess.Popen([sys.executable, "-c", HOLD], cwd=REPO, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                             text=True)
    try:
        held = int(other.stdout.readline())
        net, lock = claim_net()
        assert net != held
        lock.close()
    finally:
        other.communicate("", timeout=10)
    net, lock = claim_net()
    assert net == held  # the first free one again
    lock.close()
