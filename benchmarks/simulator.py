"""The simulated Aibo's speed: control steps/s, camera frames/s end to end, real-time factor.

Control steps: AiboPlatform.step in one process (the physics' own ceiling). Camera: the aibo
service renders and JPEG-encodes nose frames while its control loop runs at 100 Hz in real time;
perception decodes them and finds the blobs; frames/s are counted at perception's output. The
real-time factor is simulated seconds per wall second over the same window. Last line: JSON.
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: rigs.*, benchmarks.*
import services  # noqa: E402,F401  (first: one BLAS thread per process, see services/__init__.py)

import argparse
import contextlib
import json
import os
import tempfile
import time

import numpy as np

from bus_schema import Clock, decode  # noqa: E402
from rigs.harness import Probe, dogged, free_port, stop  # noqa: E402


@contextlib.contextmanager
def quiet_stdout():
    """pybullet prints to fd 1 from C; keep the table clean."""
    sys.stdout.flush()
    saved = os.dup(1)
    with open(os.devnull, "w") as devnull:
        os.dup2(devnull.fileno(), 1)
        try:
            yield
        finally:
            os.dup2(saved, 1)
            os.close(saved)


def control_steps_per_s(seconds: float) -> tuple[float, float]:
    with quiet_stdout():
        from services.platforms.aibo.platform import AiboPlatform
        aibo = AiboPlatform(seed=0, command="move")
    with aibo:
        aibo.step(np.array([0.1, 0.2]), 0.01)
        n, start = 0, time.perf_counter()
        while time.perf_counter() - start < seconds:
            aibo.step(np.array([0.1, 0.2]), 0.01)
            n += 1
        wall = time.perf_counter() - start
    return n / wall, n * 0.01 / wall


def camera_pipeline(seconds: float, camera_hz: float) -> dict:
    work = Path(tempfile.mkdtemp(prefix="dogged-platform-"))
    router = f"tcp/127.0.0.1:{free_port()}"
    c = ["--connect", router]
    procs = [dogged("run", "router", "--listen", router, log=work / "router.log")]
    procs += [dogged("run", "aibo", "--command", "move", "--rate", "100", "--camera-hz", str(camera_hz), *c,
                     log=work / "aibo.log"),
              dogged("run", "perception", *c, log=work / "perception.log"),
              dogged("run", "demonstrator", "--teacher", "hold", "--role", "default", *c, log=work / "default.log"),
              dogged("run", "arbitrator", *c, log=work / "arbitrator.log")]
    probe = Probe(router)
    clocks = probe.record("robot/aibo/clock")
    try:
        probe.wait_for(lambda: probe.counter("perception/perception", "frames") > 10, 90, "frames flowing")
        time.sleep(2)
        f0, t0 = probe.counter("perception/perception", "frames"), probe.counter("aibo/aibo", "tick")
        c0, w0 = decode(Clock, clocks[-1][1], "c").sim_time, time.monotonic()
        time.sleep(seconds)
        f1, t1 = probe.counter("perception/perception", "frames"), probe.counter("aibo/aibo", "tick")
        c1, w1 = decode(Clock, clocks[-1][1], "c").sim_time, time.monotonic()
        ms = probe.state("perception/perception", "ms_per_frame")
        commands = probe.state("aibo/aibo", "rates").get("commands", 0)
    finally:
        probe.close()
        stop(*reversed(procs))
    wall = w1 - w0
    return {"camera_fps": (f1 - f0) / wall, "control_hz": (t1 - t0) / wall, "realtime_factor": (c1 - c0) / wall,
            "perception_ms": ms, "commands_per_s": commands}


def main(quick: bool) -> dict:
    steps, rtf_max = control_steps_per_s(5 if quick else 20)
    cam = camera_pipeline(10 if quick else 30, camera_hz=60)
    figures = {"control_steps_per_s": round(steps, 1), "camera_fps": round(cam["camera_fps"], 1),
               "realtime_factor": round(cam["realtime_factor"], 3), "control_hz_with_camera": round(cam["control_hz"],
                                                                                                    1),
               "realtime_factor_unpaced": round(rtf_max, 2), "perception_ms_per_frame": cam["perception_ms"]}
    print(f"{'figure':<44}{'value':>10}")
    rows = [("control steps/s (10 ms each, physics alone)", figures["control_steps_per_s"]),
            ("sim seconds per wall second, unpaced", figures["realtime_factor_unpaced"]),
            ("camera frames/s end to end (asked 60)", figures["camera_fps"]),
            ("control ticks/s meanwhile (asked 100)", figures["control_hz_with_camera"]),
            ("real-time factor meanwhile", figures["realtime_factor"]),
            ("perception ms per frame (decode + blobs)", figures["perception_ms_per_frame"]),
            ("commands applied/s meanwhile", cam["commands_per_s"])]
    for name, value in rows:
        print(f"{name:<44}{value:>10}")
    return figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a shorter run (under a minute)")
    print(json.dumps(main(parser.parse_args().quick)))
