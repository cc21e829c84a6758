"""Malformed payloads on every key are rejected and counted, and the loop keeps its rate."""

import msgpack
import numpy as np

from bus_schema import Input, TeachSwitch, TrainingPair, encode
from rigs.harness import Probe, dogged, stop
from services.waiting import poll


def bad_payloads(good: bytes) -> list[bytes]:
    data = msgpack.unpackb(good)
    wrong_version = msgpack.packb({**data, "v": 99}, use_bin_type=True)
    missing = msgpack.packb({k: v for k, v in list(data.items())[:-1]}, use_bin_type=True)
    return [b"\x00garbage\xff", wrong_version, missing, b"\x91" * 300_000, msgpack.packb([1, 2, 3])]


def vector_payloads() -> list[bytes]:
    nan = encode(Input(1, 0.0, np.array([0.0, np.nan, 0.0, 0.0])))
    short = encode(Input(1, 0.0, np.zeros(3)))
    inf = encode(TrainingPair("e", 1, 1, np.zeros(4), np.array([np.inf, 0.0]), "teacher/t"))
    return [nan, short, inf]


def test_malformed_payloads_rejected_counted_loop_keeps_rate(router, tmp_path):
    connect = ["--connect", router]
    procs = [dogged("run", "platform", "--param", "dims=2", "--rate", "100", *connect, log=tmp_path / "p.log"),
             dogged("run", "demonstrator", "--teacher", "sine", "--on", *connect, log=tmp_path / "t.log"),
             dogged("run", "learner", "--learner", "knn", *connect, log=tmp_path / "l.log"),
             dogged("run", "arbitrator", *connect, log=tmp_path / "a.log")]
    probe = Probe(router)
    try:
        probe.wait_for(lambda: probe.counter("platform/platform", "commands") > 200, 60, "the loop running")
        bad = bad_payloads(encode(TeachSwitch("", True))) + vector_payloads()
        keys = ["dl/main/input", "dl/main/proposal/teacher/sine", "dl/main/proposal/learner/learner",
                "dl/main/proposal/stranger/x", "dl/main/command", "dl/main/train", "dl/main/teach",
                "dl/main/arbitrator/select"]
        n = len(bad)
        expected = {"platform/platform": n,              # command
                    "teacher/sine": 2 * n,              # input, teach
                    "learner/learner": 2 * n,           # input, train
                    "arbitrator/arbitrator": 5 * n}     # input, 3 proposal keys, select
        probe.wait_for(lambda: expected.keys() <= probe.status.keys(), 10, "every service's status")
        before = {m: probe.counter(m, "rejected") for m in expected}
        ticks0, commands0 = probe.counter("platform/platform", "inputs"), probe.counter("platform/platform", "commands")
        for key in keys:
            for payload in bad:
                probe.put(key, payload)

        def rejected_since() -> dict:
            return {m: probe.counter(m, "rejected") - before[m] for m in before}
        # every rejection counted, over enough ticks (1.5 s at 100 Hz) to tell whether the loop kept its rate
        poll(lambda: rejected_since() == expected and probe.counter("platform/platform", "inputs") - ticks0 > 150, 15)
        ticks = probe.counter("platform/platform", "inputs") - ticks0
        answered = probe.counter("platform/platform", "commands") - commands0
        got = rejected_since()
        assert got == expected, got
        by_key = probe.state("arbitrator/arbitrator", "rejected_by_key")
        assert by_key["dl/main/proposal/stranger/x"] == n
        assert ticks > 150 and answered >= ticks - 2, (ticks, answered)
        assert probe.state("platform/platform", "rates")["commands"] > 90
        log = (tmp_path / "a.log").read_text()
        assert "rejected payload (1 so far on this key): dl/main/input: field '*': not a msgpack payload" in log
    finally:
        probe.close()
        assert stop(*procs) == [0, 0, 0, 0]
