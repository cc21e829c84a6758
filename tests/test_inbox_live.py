"""A service's inbox is bounded, as real processes: what comes past its budget is dropped on arrival and
counted; every message sent is accounted for (recorded, rejected on decode or dropped), the recorder keeps
running and its file reads back. Over TCP (no shared memory since issue 31) the recorder rejects a flood of
256 KiB junk as fast as it comes, so the flood ends with messages larger than the whole 1 MiB budget, which
no inbox can hold (through shared memory the flood alone came faster than the recorder read it)."""
import time

import numpy as np

from bus_schema import Input, encode
from rigs.harness import Probe, dogged, stop
from services.recording.reader import is_finished, iter_samples, run_files

FLOOD, FLOOD_BYTES = 300, 256 * 1024
BEYOND, BEYOND_BYTES = 10, 2 * 1024 * 1024  # each past the recorder's 1 MiB inbox on its own


def test_a_flood_past_the_recorders_inbox_is_dropped_counted_and_the_recording_goes_on(router, tmp_path):
    recorder = dogged("run", "recorder", "--out", str(tmp_path / "rec"), "--inbox-mb", "1", "--connect", router,
                      log=tmp_path / "recorder.log")
    probe = Probe(router)
    try:
        probe.wait_for(lambda: probe.state("recorder/recorder", "recording") is True, 60, "the recorder")
        junk = b"\x00" * FLOOD_BYTES  # not an Input: each one that gets in is rejected on decode
        for _ in range(FLOOD):
            probe.put("dl/main/input", junk)
        for _ in range(BEYOND):
            probe.put("dl/main/input", b"\x00" * BEYOND_BYTES)
        sent = FLOOD + BEYOND
        dropped = probe.wait_for(lambda: (c := probe.counter("recorder/recorder", "rejected")
                                          + probe.counter("recorder/recorder", "inbox_dropped")) >= sent and c, 30,
                                 "every flooded message accounted for")
        assert dropped == sent, f"{dropped} accounted for, {sent} sent"
        print(f"{FLOOD} messages of {FLOOD_BYTES // 1024} KiB: {probe.counter('recorder/recorder', 'inbox_dropped')} "
              f"dropped on arrival, {probe.counter('recorder/recorder', 'rejected')} rejected on decode")
        assert probe.counter("recorder/recorder", "inbox_dropped") >= BEYOND, "a 1 MiB inbox took 2 MiB at once"
        for tick in range(5):  # after the flood, the recording goes on
            probe.put("dl/main/input", encode(Input(tick, time.time(), np.zeros(2))))
        probe.wait_for(lambda: recorded_ticks(tmp_path / "rec") == [0, 1, 2, 3, 4], 30,
                       "the inputs after the flood in the file (a chunk is finished every 0.5 s)")
    finally:
        probe.close()
        assert stop(recorder) == [0]
    assert all(is_finished(f) for f in run_files(tmp_path / "rec"))
    assert recorded_ticks(tmp_path / "rec") == [0, 1, 2, 3, 4]
    log = (tmp_path / "recorder.log").read_text()
    assert "inbox full" in log and "dropped on arrival" in log, log[-2000:]


def recorded_ticks(run) -> list[int]:
    try:
        return [s.decoded().tick for s in iter_samples(run, {"dl/main/input"}, truncated=[])]
    except FileNotFoundError:  # no file yet
        return []
