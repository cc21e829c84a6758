"""The Aibo as a service: ears follow the mode published on the bus; frames, handler, arena, watchdog."""
import time

import numpy as np

from bus_schema import (Applied, ArenaReset, Command, Frame, Handle, RobotState, SpacesMessage, decode, encode)
from rigs.harness import Probe, dogged, dogged_ok, stop
from services.perception.jpeg import decode_rgb
from services.platforms.aibo.sim import EAR_COLOURS


def latest(bucket, cls, dims=None):
    key, raw, _ = bucket[-1]
    return decode(cls, raw, key, dims)


def test_aibo_service_on_the_bus(router, tmp_path):
    aibo = dogged("run", "aibo", "--rate", "50", "--camera-hz", "10", "--watchdog", "0.3", "--connect", router,
                  log=tmp_path / "aibo.log")
    probe = Probe(router)
    try:
        # stand in for an arbitrator: the platform ticks once one is alive
        token = probe.session.liveliness().declare_token("dl/main/alive/commanding/test")
        states, frames, applied = (probe.record(k) for k in ("robot/aibo/state", "robot/aibo/camera",
                                                             "dl/main/applied"))
        probe.wait_for(lambda: probe.counter("aibo/aibo", "inputs") > 20 and frames, 60, "ticks and frames")
        spaces = [r.ok for r in probe.session.get("robot/aibo/spaces", timeout=5) if r.ok]
        assert decode(SpacesMessage, spaces[0].payload.to_bytes(), "k").spaces["output"]["names"][16] == "tail_tilt"
        frame = latest(frames, Frame)
        assert decode_rgb(frame.jpeg).shape == (160, 208, 3) and frame.sim_time > 0

        pub = probe.session.declare_publisher("dl/main/command")
        tick = ears_show_each_mode(probe, pub, states)

        # the handler's joints win over the arbitrator's: the applied command shows the handled value
        handle = probe.session.declare_publisher("robot/aibo/handle")
        mask, q = np.zeros(18), np.zeros(18)
        mask[16], q[16] = 1, 0.5
        for _ in range(10):
            handle.put(encode(Handle(mask, q)))
            time.sleep(0.02)
        probe.wait_for(lambda: probe.counter("aibo/aibo", "handled") > 0, 10, "the handle taken")
        used = tick  # a command for a newer tick than the last one applied, or nothing new is applied
        tick = probe.wait_for(lambda: (t := probe.counter("aibo/aibo", "tick")) > used and t, 10, "a newer tick")
        for _ in range(10):
            pub.put(encode(Command(tick, time.time(), np.zeros(18), "student", "test/x", 1.0)))
            time.sleep(0.02)
        last = latest(applied, Applied, {"y": 18})
        assert last.y[16] == 0.5 and last.y[17] == 0.0, last.y

        arena_on_request(probe, states, router)
        assert aibo.poll() is None

        # watchdog: no fresh command -> the robot holds still
        held = probe.counter("aibo/aibo", "held")
        time.sleep(2.5)
        assert probe.counter("aibo/aibo", "held") > held + 20
        assert probe.counter("aibo/aibo", "rejected") == 4  # the unknown ball and the three hostile resets
        token.undeclare()
    finally:
        probe.close()
        assert stop(aibo) == [0]


def ears_show_each_mode(probe: Probe, pub, states) -> int:
    """Commands in each mode turn the ears to its colour; returns the last tick commanded."""
    for mode in ("teacher", "student", "unsure"):
        tick = probe.counter("aibo/aibo", "tick")  # one it has published (a later one is refused)
        for _ in range(10):
            pub.put(encode(Command(tick, time.time(), np.zeros(18), mode, "test/x", 1.0)))
            time.sleep(0.02)
        probe.wait_for(lambda mode=mode: states and latest(states, RobotState, {}).ear_mode == mode, 10, f"ears {mode}")
        rgba = latest(states, RobotState).ear_rgba
        assert np.allclose(rgba, EAR_COLOURS[mode], atol=1e-3), (mode, rgba)
    return tick


def arena_on_request(probe: Probe, states, router: str) -> None:
    """The arena on request: hide orange, pink at a known spot."""
    probe.put("robot/aibo/arena", encode(ArenaReset(3, {"pink": [0.6, 0.0], "orange": None})))
    probe.wait_for(lambda: probe.counter("aibo/aibo", "resets") == 1, 10, "the reset")
    probe.wait_for(lambda: abs(latest(states, RobotState).balls["pink"][0] - 0.6) < 0.05, 10, "pink placed")
    # the same from the command line, confirmed from the robot's state; a bad ball is refused by name
    done = dogged_ok("arena", "--seed", "4", "--ball", "pink=0.7,0.2", "--ball", "orange=off", endpoint=router)
    assert done.returncode == 0 and "pink [0.7, 0.2], orange off" in done.stdout, done.stderr
    assert np.allclose(latest(states, RobotState).balls["pink"][:2], [0.7, 0.2], atol=0.05)
    refused = dogged_ok("arena", "--ball", "blue=0.5,0", endpoint=router, timeout=30)
    assert refused.returncode == 1 and "did not confirm the arena reset" in refused.stderr
    # no ball given: confirmed by the simulated time starting again, not by any state coming
    resets = probe.counter("aibo/aibo", "resets")
    seeded = dogged_ok("arena", "--seed", "5", endpoint=router)
    assert seeded.returncode == 0 and "arena 5: balls as seeded" in seeded.stdout, seeded.stderr
    probe.wait_for(lambda: probe.counter("aibo/aibo", "resets") == resets + 1, 10, "the reset counted")
    out_of_range = dogged_ok("arena", "--seed", str(2 ** 32), endpoint=router)
    assert out_of_range.returncode == 2 and "seed" in out_of_range.stderr, out_of_range.stderr
    # hostile but well-formed resets are refused before anything is reset (seed -1 crashed the Aibo
    # after it had rebuilt the world: issue 12)
    resets = probe.counter("aibo/aibo", "resets")
    for hostile in (ArenaReset(-1, {}), ArenaReset(2 ** 40, {}), ArenaReset(1, {"pink": [1e9, 0.0]})):
        probe.put("robot/aibo/arena", encode(hostile))
    probe.wait_for(lambda: probe.counter("aibo/aibo", "rejected") == 4, 10, "three hostile resets refused")
    assert probe.counter("aibo/aibo", "resets") == resets
