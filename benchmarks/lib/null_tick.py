"""The point loop's tick with no work in it: the same processes and hops (the platform's input to a learner,
its proposal to an arbitrator, the command back; the loop's teacher is switched off and does not even hear
the inputs), each process handing samples from the Zenoh callback to its main thread and publishing as the
services do (as zenoh_echo's echo does), none decoding, deciding or learning. Beside the floor (two
processes, 1.5 round trips) it says what the loop's shape costs; beside the tick, what the services' own
work and waits cost.

    python benchmarks/lib/null_tick.py answer <router> <seconds> <name>   (a learner that echoes)
    python benchmarks/lib/null_tick.py decide <router> <seconds>          (an arbitrator that waits for every answer)
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: rigs.*, benchmarks.*
import services  # noqa: E402,F401  (first: one BLAS thread per process, see services/__init__.py)

import subprocess  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
import zenoh  # noqa: E402

from services.bus.config import zenoh_config  # noqa: E402
from services.bus.inbox import Inbox  # noqa: E402
from services.bus.publishers import sensor_publisher, wait_matching  # noqa: E402
from benchmarks.lib.zenoh_echo import echo  # noqa: E402

INPUT, PROPOSALS, COMMAND = "bench/null/input", "bench/null/proposal", "bench/null/command"
ANSWERERS = ("learner",)  # a teacher switched on would be one more
WARM_UP = 100


def decide(router: str, seconds: float) -> None:
    """The command goes out once every answer to a tick (its first 8 bytes) has come."""
    inbox, heard = Inbox(), {}
    with zenoh.open(zenoh_config(connect=[router])) as session:
        pub = sensor_publisher(session, COMMAND)
        sub = session.declare_subscriber(f"{PROPOSALS}/*", inbox.callback("proposal"))
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            for _, key, raw, _ in inbox.drain(0.1):
                tick = raw[:8]
                heard.setdefault(tick, set()).add(key)
                if len(heard[tick]) == len(ANSWERERS):
                    del heard[tick]
                    pub.put(raw)
        del sub


def ticks(router: str, rate_hz: float, count: int) -> np.ndarray:
    """Milliseconds from each input's put to its command's arrival (NaN: none within a second), one input every
    1/rate_hz seconds, after WARM_UP more not counted; the answerers and the arbitrator started for the run."""
    seconds = (count + WARM_UP) / rate_hz + 30
    me = str(Path(__file__).resolve())
    procs = [subprocess.Popen([sys.executable, me, "answer", router, str(seconds), name], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL) for name in ANSWERERS]
    procs.append(subprocess.Popen([sys.executable, me, "decide", router, str(seconds)], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL))
    inbox, out = Inbox(), np.full(count + WARM_UP, np.nan)
    try:
        with zenoh.open(zenoh_config(connect=[router])) as session:
            pub = sensor_publisher(session, INPUT)
            sub = session.declare_subscriber(COMMAND, inbox.callback("command"))
            if not wait_matching(pub, 20.0):
                raise TimeoutError("the null tick's answerers never subscribed")
            time.sleep(2.0)  # the arbitrator subscribed too
            next_at = time.perf_counter()
            for i in range(count + WARM_UP):
                next_at += 1.0 / rate_hz
                time.sleep(max(0.0, next_at - time.perf_counter()))
                payload = i.to_bytes(8, "little") + b"x" * 88
                started = time.perf_counter()
                pub.put(payload)
                while (item := inbox.get(1.0)) is not None:
                    if item[2][:8] == payload[:8]:
                        out[i] = (time.perf_counter() - started) * 1e3
                        break
            del sub
    finally:
        for p in procs:
            p.kill()
            p.wait()
    return out[WARM_UP:]


if __name__ == "__main__":
    if sys.argv[1] == "answer":  # a learner that says the input again as its proposal
        echo(sys.argv[2], float(sys.argv[3]), INPUT, f"{PROPOSALS}/{sys.argv[4]}")
    else:
        decide(sys.argv[2], float(sys.argv[3]))
