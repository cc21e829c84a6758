"""`dogged play`: a recorded run's inputs, published in place of the platform into a live loop (real
processes, a real router), every one in its recorded order, and the live learner learns from them."""
import json

import numpy as np

from bus_schema import Input, decode, encode
from rigs.harness import Probe, dogged, stop, wait_until
from services.platforms.point import PointPlatform
from services.recording.writer import RunWriter

TICKS = 240  # 8 s at 30 Hz, played at 4x


def a_recording(folder):
    point = PointPlatform(dims=2, seed=5)
    writer = RunWriter(folder, "recorder", 10**9, 3600.0)
    writer.add_metadata("spaces dl/main", {"spaces": json.dumps(point.spaces.to_dict())})
    xs = []
    for tick in range(1, TICKS + 1):
        xs.append(point.observe())
        writer.write("dl/main/input", Input, encode(Input(tick, 100 + tick / 30, xs[-1])), tick, tick)
        point.step(np.array([0.3, -0.2]), 1 / 30)
    writer.close()
    return np.array(xs)


def test_play_publishes_the_recorded_inputs_into_a_live_loop(router, tmp_path):
    recorded = a_recording(tmp_path / "run")
    c = ["--connect", router]
    loop = [dogged("run", "demonstrator", "--teacher", "sine", "--on", *c, log=tmp_path / "teacher.log"),
            dogged("run", "learner", "--learner", "lwpr", *c, log=tmp_path / "learner.log"),
            dogged("run", "arbitrator", *c, log=tmp_path / "arbitrator.log")]
    probe = Probe(router)
    inputs = probe.record("dl/main/input")
    try:
        player = dogged("play", str(tmp_path / "run"), "--speed", "4", *c, log=tmp_path / "play.log")
        assert player.wait(120) == 0, (tmp_path / "play.log").read_text()
        played = np.array([decode(Input, raw, key, {"x": 4}).x for key, raw, _ in inputs])
        assert np.array_equal(played, recorded), f"{len(played)} inputs played of {TICKS}"
        wait_until(lambda: probe.counter("learner/learner", "learned") >= TICKS - 5, 10, "the pairs learned")
        assert "playing 240 inputs of main at 120.0 Hz (4x)" in (tmp_path / "play.log").read_text()
    finally:
        probe.close()
        stop(*loop)
