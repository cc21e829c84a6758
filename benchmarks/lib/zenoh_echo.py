"""A floor for one bus hop: a Zenoh ping-pong between two Python processes joined to the router as
the services are (peers on 127.0.0.1), each handing samples from the Zenoh callback to its main
thread as every service does (services.bus.inbox) and publishing as they do (sensor_publisher).
A tick crosses three such hops (input -> learner, proposal -> arbitrator, command -> platform),
so one and a half of these round trips is what the tick costs before any work."""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: rigs.*, benchmarks.*
import services  # noqa: E402,F401  (first: one BLAS thread per process, see services/__init__.py)

import time  # noqa: E402

import numpy as np  # noqa: E402
import zenoh  # noqa: E402

from services.bus.config import zenoh_config  # noqa: E402
from services.bus.inbox import Inbox  # noqa: E402
from services.bus.publishers import sensor_publisher, wait_matching  # noqa: E402

PING, PONG = "bench/echo/ping", "bench/echo/pong"
WARM_UP = 200


def echo(router: str, seconds: float, hear: str = PING, say: str = PONG) -> None:
    """Each sample heard on `hear` said again on `say`, for `seconds`."""
    inbox = Inbox()
    with zenoh.open(zenoh_config(connect=[router])) as session:
        pub = sensor_publisher(session, say)
        sub = session.declare_subscriber(hear, inbox.callback("ping"))
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            for _, _, raw, _ in inbox.drain(0.1):
                pub.put(raw)
        del sub


def round_trips(router: str, count: int, size: int = 96, rate_hz: float = 0.0, warm_up: int = WARM_UP,
                say: str = PING, hear: str = PONG) -> np.ndarray:
    """Seconds per round trip (NaN for one whose echo never came within a second): back to back, or
    one every 1/rate_hz seconds (as ticks come: both processes idle, and wake, in between), after
    `warm_up` more not counted. Said on `say`, its echo heard on `hear`."""
    inbox, out = Inbox(), np.full(count + warm_up, np.nan)
    with zenoh.open(zenoh_config(connect=[router])) as session:
        pub = sensor_publisher(session, say)
        sub = session.declare_subscriber(hear, inbox.callback("pong"))
        if not wait_matching(pub, 10.0):
            raise TimeoutError("the echo process never subscribed")
        next_at = time.perf_counter()
        for i in range(count + warm_up):
            if rate_hz:
                next_at += 1.0 / rate_hz
                time.sleep(max(0.0, next_at - time.perf_counter()))
            payload = i.to_bytes(8, "little") + b"x" * (size - 8)
            started = time.perf_counter()
            pub.put(payload)
            while (item := inbox.get(1.0)) is not None:
                if item[2][:8] == payload[:8]:
                    out[i] = time.perf_counter() - started
                    break
        del sub
    return out[warm_up:]


if __name__ == "__main__":  # <router> <seconds> [<key heard> <key said>]
    echo(sys.argv[1], float(sys.argv[2]), *sys.argv[3:5])
