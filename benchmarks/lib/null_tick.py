"""The point loop's tick with no work in it: the same processes and hops (the platform's input to a learner,
its proposal to an arbitrator, the command back; the loop's teacher is switched off and does not even hear
the inputs), each process handing samples from the Zenoh callback to its main thread and publishing as the
services do (zenoh_echo's echo, twice in a chain), none decoding, deciding or learning. Beside the floor (two
processes, 1.5 round trips) it says what the loop's shape costs; beside the tick, what the services' own
work and waits cost."""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.lib import zenoh_echo

INPUT, PROPOSAL, COMMAND = "bench/null/input", "bench/null/proposal", "bench/null/command"
WARM_UP = 100
READY_S = 30.0  # for the chain's two processes to start and link


def ticks(router: str, rate_hz: float, count: int) -> np.ndarray:
    """Milliseconds from each input's put to its command's arrival (NaN: none within a second), one input every
    1/rate_hz seconds, after WARM_UP more not counted; the learner and the arbitrator started for the run."""
    seconds = str(READY_S + (count + WARM_UP) / rate_hz + 30)
    echo = str(Path(zenoh_echo.__file__).resolve())
    procs = [subprocess.Popen([sys.executable, echo, router, seconds, hear, say], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL) for hear, say in ((INPUT, PROPOSAL), (PROPOSAL, COMMAND))]
    try:
        ready_by = time.monotonic() + READY_S
        while np.isnan(zenoh_echo.round_trips(router, 1, warm_up=0, say=INPUT, hear=COMMAND)).any():
            if time.monotonic() > ready_by:  # (the learner's subscription alone lets the first put through)
                raise TimeoutError(f"the null tick's chain did not answer within {READY_S:g} s")
        return zenoh_echo.round_trips(router, count, rate_hz=rate_hz, warm_up=WARM_UP, say=INPUT, hear=COMMAND) * 1e3
    finally:
        for p in procs:
            p.kill()
            p.wait()
