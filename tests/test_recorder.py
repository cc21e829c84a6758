"""The recorder without a bus: MCAP files that mcap's own reader opens, rotation, a cut file read and
repaired, a full disk reported and survived, the profile's recorder."""
import errno
import io
import json
import logging
import shutil

import numpy as np
import pytest
from mcap.reader import make_reader

from bus_schema import Command, Input, Proposal, SpacesMessage, Status, TrainingPair, encode
from bus_schema.catalog import LOSSLESS, payload_of
from services.boxes import recorder as recorder_box
from services.boxes.recorder import Recording
from services.platforms.point import PointPlatform
from services.recording.reader import is_finished, iter_samples, read_metadata, repair, run_files
from services.recording.runs import load_run
from services.recording.writer import RunWriter
from services.supervisor.profile import ProfileError, load_profile

LOG = logging.getLogger("test.recorder")


def samples(n: int):
    """n ticks of a loop: input, learner proposal, command, and a training pair every other tick."""
    for t in range(1, n + 1):
        x = np.array([t * 0.01, -t * 0.02])
        yield "dl/main/input", encode(Input(t, 1e9 + t / 100, x))
        yield "dl/main/proposal/learner/l", encode(Proposal(t, "learner/l", np.array([0.5]), 0.3, learned=t // 2))
        yield "dl/main/command", encode(Command(t, 1e9 + t / 100, np.array([0.5]), "student", "learner/l", 0.3))
        if t % 2:
            yield "dl/main/train", encode(TrainingPair("e1", (t + 1) // 2, t, x, np.array([np.sin(t)]), "teacher/s"))


def record(folder, n=200, upkeep=False, **writer_args):
    writer = RunWriter(folder, "recorder", **{"rotate_bytes": 10**9, "rotate_s": 3600.0, **writer_args})
    rec = Recording(writer, LOG)
    for i, (key, raw) in enumerate(samples(n)):
        rec.on_sample(key, raw, 10**18 + i)
        if upkeep:
            rec.upkeep()
    return rec


def test_a_recording_reads_back_with_mcaps_own_reader(tmp_path):
    rec = record(tmp_path)
    rec.on_sample("dl/main/status/learner/l", encode(Status("learner", "l", 1, {"proposals": 200}, {})), 2 * 10**18)
    rec.writer.close()
    [path] = run_files(tmp_path)
    assert is_finished(path)
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        counts = {summary.channels[c].topic: n for c, n in summary.statistics.channel_message_counts.items()}
        assert counts == {"dl/main/input": 200, "dl/main/proposal/learner/l": 200, "dl/main/command": 200,
                          "dl/main/train": 100, "dl/main/status/learner/l": 1}
        assert {s.name for s in summary.schemas.values()} == {"dogged.Input", "dogged.Proposal", "dogged.Command",
                                                             "dogged.TrainingPair", "dogged.Status"}
        assert all(s.encoding == "jsonschema" for s in summary.schemas.values())
        assert all(c.message_encoding == "msgpack" for c in summary.channels.values())
        assert summary.statistics.chunk_count >= 1 and summary.chunk_indexes
        seqs = [m.sequence for _, c, m in reader.iter_messages(topics=["dl/main/train"])]
        assert seqs == list(range(1, 101))
    decoded = [s.decoded() for s in iter_samples(tmp_path, {"dl/main/proposal/learner/l"})]
    assert [p.learned for p in decoded] == [t // 2 for t in range(1, 201)]
    stamps = [s.publish_ns for s in iter_samples(tmp_path, {"dl/main/input"})]
    assert stamps[0] == int((1e9 + 0.01) * 1e9)  # the input's stamp is the publish time


def test_a_payload_that_does_not_decode_is_rejected_not_recorded(tmp_path):
    rec = record(tmp_path, n=5)
    rec.on_sample("dl/main/input", b"\x93garbage", 1)
    rec.on_sample("dl/main/input", encode(Input(6, 1.0, np.array([np.nan, 0.0]))), 2)
    rec.on_sample("dl/main/alive/learner/l", b"", 3)
    rec.writer.close()
    assert rec.rejects.counts["dl/main/input"] == 2 and rec.counts["unknown_keys"] == 1
    assert sum(1 for s in iter_samples(tmp_path) if s.key == "dl/main/input") == 5


def test_once_the_spaces_are_known_vector_lengths_are_checked_too(tmp_path):
    rec = record(tmp_path, n=3)
    rec.on_sample("dl/main/input", encode(Input(4, 1.0, np.zeros(5))), 1)  # spaces unknown: any length
    point = PointPlatform(dims=2)
    rec.on_spaces("dl/main/spaces", encode(SpacesMessage(point.spaces.to_dict())))
    rec.on_sample("dl/main/input", encode(Input(5, 1.0, np.zeros(5))), 2)
    rec.on_sample("dl/main/input", encode(Input(6, 1.0, np.zeros(4))), 3)
    rec.on_sample("dl/main/command", encode(Command(6, 1.0, np.zeros(3), "student", "l", 0.5)), 4)
    rec.on_spaces("dl/main/spaces", b"junk")  # known already: a later answer changes nothing
    rec.writer.close()
    assert rec.rejects.counts == {"dl/main/input": 1, "dl/main/command": 1}
    assert sum(1 for s in iter_samples(tmp_path) if s.key == "dl/main/input") == 5
    assert "spaces dl/main" in read_metadata(tmp_path)


def test_files_rotate_by_size_and_continue_after_the_ones_there(tmp_path):
    rec = record(tmp_path, n=2000, upkeep=True, rotate_bytes=20_000, flush_s=0.0)
    rec.writer.close()
    files = run_files(tmp_path)
    assert len(files) >= 3 and all(is_finished(p) for p in files)
    assert sum(1 for s in iter_samples(tmp_path) if s.key == "dl/main/command") == 2000
    again = RunWriter(tmp_path, "recorder", 10**9, 3600.0)
    assert again.next_path().name.startswith(f"recorder-{len(files):04d}-")


def test_files_rotate_by_age(tmp_path):
    rec = record(tmp_path, n=5, upkeep=True, rotate_s=0.0)  # every upkeep finds the file old enough
    rec.writer.close()
    files = run_files(tmp_path)
    assert len(files) == 5 * 3 + 3 and all(is_finished(p) for p in files)  # 5 ticks: 18 samples, a file each
    assert sum(1 for _ in iter_samples(tmp_path)) == 18


def test_a_cut_file_reads_up_to_its_last_chunk_and_is_repaired(tmp_path):
    rec = record(tmp_path, n=100, flush_s=0.0)
    rec.writer.add_metadata("spaces dl/main", {"spaces": json.dumps({"input": 2})})
    rec.upkeep()  # the chunk so far is whole on disk
    for i, (key, raw) in enumerate(samples(50)):  # then more, in a chunk never finished
        rec.on_sample(key, raw, 2 * 10**18 + i)
    [path] = run_files(tmp_path)
    cut = tmp_path / "cut" / path.name
    cut.parent.mkdir()
    shutil.copy(path, cut)  # what a SIGKILL leaves: no summary, no footer, the last chunk in memory lost
    with open(cut, "ab") as f:
        f.write(b"\x06" + b"\x00" * 5)  # and a record cut in its middle
    assert not is_finished(cut)
    truncated = []
    inputs = [s for s in iter_samples(cut, truncated=truncated) if s.key == "dl/main/input"]
    assert len(inputs) == 100 and truncated
    assert repair(cut) == 350 and is_finished(cut)
    with open(cut, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary.statistics.message_count == 350
    assert json.loads(read_metadata(cut)["spaces dl/main"]["spaces"]) == {"input": 2}


def test_a_full_disk_is_an_error_and_recording_resumes_when_it_can(tmp_path, monkeypatch):
    monkeypatch.setattr(recorder_box, "RETRY_S", 0.0)
    full = {"on": True}

    def open_file(path, mode):
        return open("/dev/full" if full["on"] else path, mode)  # /dev/full: every write is ENOSPC

    writer = RunWriter(tmp_path, "recorder", 10**9, 3600.0, flush_s=0.0, open_file=open_file)
    rec = Recording(writer, LOG)
    for i, (key, raw) in enumerate(samples(50)):
        rec.on_sample(key, raw, i)
        rec.upkeep()
    assert "No space left on device" in rec.error and rec.counts["write_errors"] >= 1
    assert rec.counts["not_recorded"] >= 1
    full["on"] = False
    for i, (key, raw) in enumerate(samples(10)):
        rec.on_sample(key, raw, 100 + i)
    writer.close()
    assert rec.error == "" and rec.report()[1]["error"] == ""
    assert sum(1 for s in iter_samples(tmp_path) if s.key == "dl/main/input") == 10


class FillingDisk:
    """Files on a disk that fills: while `full`, every write raises ENOSPC, though new files can still be
    made (what a real full filesystem does; /dev/full takes no file at all). A buffer of one byte: each write
    reaches the disk, as one does once a file's buffer is full."""

    def __init__(self):
        self.full = False

    def open(self, path, mode):
        disk = self

        class File(io.FileIO):
            def write(self, data):
                if disk.full:
                    raise OSError(errno.ENOSPC, "No space left on device")
                return super().write(data)
        return io.BufferedWriter(File(path, mode), buffer_size=1)


def test_files_a_full_disk_cut_open_in_mcaps_reader_once_it_has_room_again(tmp_path, monkeypatch):
    """Issue 31's soak found them cut (no summary, no footer: mcap's reader refused them) and a new empty
    file left at every retry, until the recorder happened to restart."""
    monkeypatch.setattr(recorder_box, "RETRY_S", 0.0)
    disk = FillingDisk()
    writer = RunWriter(tmp_path, "recorder", 10**9, 3600.0, flush_s=0.0, open_file=disk.open)
    rec = Recording(writer, LOG)

    def feed(n, at):
        for i, (key, raw) in enumerate(samples(n)):
            rec.on_sample(key, raw, at + i)
            rec.upkeep()
    feed(100, 0)
    disk.full = True
    feed(50, 10**6)
    assert rec.counts["write_errors"] >= 2 and len(list(tmp_path.glob("*.mcap"))) >= 2  # retried in new files
    disk.full = False
    feed(10, 2 * 10**6)
    writer.close()
    inputs = 0
    for path in run_files(tmp_path):
        with open(path, "rb") as f:
            messages = [channel.topic for _, channel, _ in make_reader(f).iter_messages()]
        assert messages, f"{path.name} holds nothing"
        inputs += messages.count("dl/main/input")
    assert inputs == 100 + 10  # all that reached the disk before it filled, and all after
    assert not list(tmp_path.glob("*.repairing"))


def test_a_file_a_kill_cut_that_a_full_disk_kept_from_repair_at_start_is_finished_once_it_can(tmp_path,
                                                                                                monkeypatch):
    """(the soak's recorder, killed, came back while its disk was full: the repair at its start failed, and
    nothing tried again)"""
    monkeypatch.setattr(recorder_box, "RETRY_S", 0.0)
    killed = record(tmp_path, n=100, flush_s=0.0, upkeep=True)
    killed.writer.abandon()  # what a SIGKILL leaves: the file unfinished
    [cut] = run_files(tmp_path)
    disk, real_repair = FillingDisk(), recorder_box.repair

    def repair(path, metadata=None):
        if disk.full:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_repair(path, metadata)
    monkeypatch.setattr(recorder_box, "repair", repair)
    disk.full = True
    writer = RunWriter(tmp_path, "recorder", 10**9, 3600.0, flush_s=0.0, open_file=disk.open)
    recorder_box.repair_unfinished(writer, LOG)  # as the restarted recorder does first
    assert not is_finished(cut)
    rec = Recording(writer, LOG)
    disk.full = False
    for i, (key, raw) in enumerate(samples(10)):
        rec.on_sample(key, raw, 10**6 + i)
        rec.upkeep()
    assert is_finished(cut)
    with open(cut, "rb") as f:
        assert sum(1 for _ in make_reader(f).iter_messages()) == 350


def test_a_file_cut_before_the_spaces_came_is_finished_with_them_and_replays_alone(tmp_path, monkeypatch):
    """(the soak's restarted recorder began a file, the disk filled before the platform's spaces came, and the
    file, repaired, replayed in its run but not alone: `dogged replay FILE` said no spaces were recorded)"""
    monkeypatch.setattr(recorder_box, "RETRY_S", 0.0)
    disk = FillingDisk()
    writer = RunWriter(tmp_path, "recorder", 10**9, 3600.0, flush_s=0.0, open_file=disk.open)
    rec = Recording(writer, LOG)

    def feed(ticks, at):
        for t in ticks:
            rec.on_sample("dl/main/input", encode(Input(t, 1e9 + t, np.zeros(4))), at + t)
            rec.upkeep()
    feed(range(1, 21), 0)
    [cut] = run_files(tmp_path)
    disk.full = True
    feed(range(21, 26), 10**6)
    rec.on_spaces("dl/main/spaces", encode(SpacesMessage(PointPlatform(dims=2).spaces.to_dict())))
    disk.full = False
    feed(range(26, 31), 2 * 10**6)
    writer.close()
    assert is_finished(cut) and "spaces dl/main" in read_metadata(cut)
    assert len(load_run(cut).ticks) == 20


def test_the_spaces_coming_while_the_disk_is_full_cost_no_crash(tmp_path, monkeypatch):
    """(the soak's recorder, restarted on a full disk, exited with ENOSPC from add_metadata when the spaces
    came, again at each restart, its supervisor's backoff growing)"""
    monkeypatch.setattr(recorder_box, "RETRY_S", 0.0)
    disk = FillingDisk()
    writer = RunWriter(tmp_path, "recorder", 10**9, 3600.0, flush_s=0.0, open_file=disk.open)
    rec = Recording(writer, LOG)
    rng = np.random.default_rng(0)
    for t in range(1, 1001):  # a file in progress, its chunk (more than the stream's buffer) not flushed yet
        rec.on_sample("dl/main/input", encode(Input(t, 1e9 + t, rng.uniform(-1, 1, 4))), t)
    disk.full = True
    rec.on_spaces("dl/main/spaces", encode(SpacesMessage(PointPlatform(dims=2).spaces.to_dict())))
    assert "No space left on device" in rec.error
    disk.full = False
    for t in range(1001, 1011):
        rec.on_sample("dl/main/input", encode(Input(t, 1e9 + t, np.zeros(4))), t)
        rec.upkeep()
    writer.close()
    assert all("spaces dl/main" in read_metadata(path) for path in run_files(tmp_path))


def test_catalog_names_every_published_key():
    assert payload_of("dl/main/train") == (TrainingPair, LOSSLESS)
    assert payload_of("dl/main/proposal/teacher/alice")[0] is Proposal
    assert payload_of("robot/aibo/camera")[0].__name__ == "Frame"
    for key in ("dl/main/alive/learner/l", "dl/main/spaces", "dl/main/proposal/x", "dogged/supervisor/p/ps", "dl"):
        assert payload_of(key) is None


def test_every_profile_records_unless_told_not_to(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text('[profile]\nname = "p"\nlog_dir = "%s"\n[services.aibo]\nbox = "aibo"\nargs = ["--robot", "dog"]\n'
                    '[services.low]\nbox = "learner"\ninstance = "walk"\n' % (tmp_path / "logs"))
    profile = load_profile(path)
    rec = profile.services[0]
    assert (rec.name, rec.box, rec.instance, rec.restart) == ("recorder", "recorder", "main", "always")
    args = list(rec.args)
    assert args[:4] == ["--instance", "walk", "--robot", "dog"]
    assert args[args.index("--out") + 1].startswith(str(tmp_path / "recordings"))
    path.write_text(path.read_text().replace('name = "p"', 'name = "p"\nrecord = false'))
    assert all(s.box != "recorder" for s in load_profile(path).services)
    path.write_text(path.read_text().replace("record = false", "recrod = false"))
    with pytest.raises(ProfileError, match="profile.recrod: unknown field"):
        load_profile(path)


def test_a_contradicting_spaces_answer_leaves_lengths_unchecked(tmp_path):
    """A stranger answering the spaces query with other sizes cannot make the run go unrecorded."""
    rec = record(tmp_path, n=1)
    rec.on_spaces("dl/main/spaces", encode(SpacesMessage(PointPlatform(dims=2).spaces.to_dict())))
    rec.on_spaces("dl/main/spaces", encode(SpacesMessage(PointPlatform(dims=3).spaces.to_dict())))
    rec.on_sample("dl/main/input", encode(Input(2, 1.0, np.zeros(4))), 1)
    rec.on_sample("dl/main/input", encode(Input(3, 1.0, np.zeros(6))), 2)
    rec.writer.close()
    assert rec.rejects.counts == {"dl/main/spaces": 1} and rec.counts["recorded"] == 6


def test_a_person_pauses_and_resumes_recording_and_the_file_says_so(tmp_path):
    from bus_schema import RecordSwitch
    writer = RunWriter(tmp_path, "recorder", rotate_bytes=10**9, rotate_s=3600.0)
    rec = Recording(writer, LOG, "recorder")
    stream = list(samples(30))
    switches = {30: RecordSwitch("", False), 60: RecordSwitch("someone-else", True), 75: RecordSwitch("recorder", True)}
    for i, (key, raw) in enumerate(stream):
        if i in switches:
            rec.on_sample("dl/main/record", encode(switches[i]), 10**18 + i)
        rec.on_sample(key, raw, 10**18 + i)
    writer.close()
    keys = [s.key for s in iter_samples(tmp_path)]
    assert keys.count("dl/main/record") == 3, "every switch recorded: the gap is explained"
    assert len(keys) - 3 == 30 + (len(stream) - 75)  # the samples before the pause and after the resume
    assert rec.counts["paused_samples"] == 45
    assert rec.report()[1]["recording"] is True


def test_an_input_that_never_arrived_is_counted_and_logged(tmp_path, caplog):
    writer = RunWriter(tmp_path, "recorder", rotate_bytes=10**9, rotate_s=3600.0)
    rec = Recording(writer, LOG)
    ticks = [1, 2, 3, 5, 6, 9, 1, 2, 2 + recorder_box.MISSED_AT_MOST + 2, 1]  # 4, 7, 8 missed; restarts; a jump
    with caplog.at_level(logging.WARNING, logger=LOG.name):
        for i, t in enumerate(ticks):
            rec.on_sample("dl/main/input", encode(Input(t, 1e9 + i, np.zeros(2))), 10**18 + i)
        rec.on_sample("dl/other/input", encode(Input(7, 1e9, np.zeros(2))), 2 * 10**18)  # another instance's own
    rec.writer.close()
    assert rec.counts["inputs_missed"] == 3 and rec.counts["input_tick_jumps"] == 1
    assert rec.counts["recorded"] == len(ticks) + 1  # counted, not refused: every input that came is recorded
    said = [r.getMessage() for r in caplog.records]
    assert any("1 input(s) never arrived before tick 5 (1 so far)" in m for m in said)
    assert not any("before tick 9" in m or "a jump" in m for m in said)  # (said at most every MISSED_LOG_S)
    assert len(said) == 1


def test_a_tick_jump_is_said_and_a_stranger_flipping_ticks_floods_no_log(tmp_path, caplog):
    writer = RunWriter(tmp_path, "recorder", rotate_bytes=10**9, rotate_s=3600.0)
    rec = Recording(writer, LOG)
    far = 3 + recorder_box.MISSED_AT_MOST + 2
    with caplog.at_level(logging.WARNING, logger=LOG.name):
        for i, t in enumerate([1, 2, far] + [1, far] * 500):  # a forged tick 1, back and forth, 1,000 times
            rec.on_sample("dl/main/input", encode(Input(t, 1e9 + i, np.zeros(2))), 10**18 + i)
    rec.writer.close()
    assert rec.counts["input_tick_jumps"] == 501 and rec.counts["inputs_missed"] == 0
    said = [r.getMessage() for r in caplog.records]
    assert len(said) == 1 and f"a jump of {far - 2} ticks (1 so far)" in said[0]


def test_inputs_while_paused_are_not_inputs_missed(tmp_path):
    writer = RunWriter(tmp_path, "recorder", rotate_bytes=10**9, rotate_s=3600.0)
    rec = Recording(writer, LOG)
    for t in range(1, 4):
        rec.on_sample("dl/main/input", encode(Input(t, 1e9 + t, np.zeros(2))), 10**18 + t)
    rec.paused = True
    for t in range(4, 10):
        rec.on_sample("dl/main/input", encode(Input(t, 1e9 + t, np.zeros(2))), 10**18 + t)
    rec.paused = False
    rec.on_sample("dl/main/input", encode(Input(10, 1e9 + 10, np.zeros(2))), 10**18 + 10)
    rec.writer.close()
    assert rec.counts["paused_samples"] == 6 and rec.counts["inputs_missed"] == 0
