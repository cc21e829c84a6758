"""The mcap the recorder needs (issue 30): pyproject.toml asks for it, the installed one has everything the
recorder uses, and a too-old one is named at the recorder's start instead of failing at its first flush."""
import logging
import re
import tomllib

import mcap
import pytest
from mcap.well_known import MessageEncoding
from mcap.writer import Writer

from bus_schema import Input, encode
from rigs.harness import REPO
from services.boxes import recorder as recorder_box
from services.recording import reader, writer
from services.recording.writer import MCAP_NEEDED, MCAP_USES, McapTooOld, RunWriter, check_mcap


def test_pyproject_asks_for_the_mcap_the_recorder_needs():
    dependencies = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["dependencies"]
    assert f"mcap>={MCAP_NEEDED}" in dependencies


def test_the_installed_mcap_has_everything_the_recorder_uses():
    check_mcap()  # else McapTooOld says what it lacks and which release to install


class SpyWriter(Writer):
    """mcap's Writer, noting each public method asked of it."""
    asked: set[str] = set()

    def __getattribute__(self, name):
        if not name.startswith("_"):
            SpyWriter.asked.add(name)
        return super().__getattribute__(name)


def test_every_writer_method_the_recorder_calls_is_checked(tmp_path, monkeypatch):
    """A file written, flushed, abandoned unfinished and repaired, as the recorder does, then one finished."""
    monkeypatch.setattr(writer, "Writer", SpyWriter)  # (the repair writes with writer.mcap_writer too)
    monkeypatch.setattr(SpyWriter, "asked", set())
    run = RunWriter(tmp_path, "recorder", rotate_bytes=10**9, rotate_s=3600.0, flush_s=0.0)
    run.add_metadata("run", {"instances": "main"})
    run.write("dl/main/input", Input, encode(Input(1, 1e9, [0.0, 1.0])), 10**18, 10**18)
    run.upkeep()
    cut = run.path
    run.abandon()
    assert reader.repair(cut) == 1
    run.write("dl/main/input", Input, encode(Input(2, 1e9, [0.0, 1.0])), 10**18 + 1, 10**18 + 1)
    run.close()
    assert {"flush", "finish", "add_message"} <= SpyWriter.asked
    assert SpyWriter.asked <= set(MCAP_USES[Writer])


def test_every_mcap_constant_the_recording_code_names_is_checked():
    named = set()
    for path in (REPO / "services" / "recording").glob("*.py"):
        named |= set(re.findall(r"\b(MessageEncoding|SchemaEncoding|CompressionType|IndexType)\.(\w+)",
                                path.read_text()))
    checked = {(owner.__name__, name) for owner, names in MCAP_USES.items() for name in names}
    assert ("MessageEncoding", "MessagePack") in named
    assert named <= checked


@pytest.fixture
def mcap_1_4(monkeypatch):
    """The installed mcap made to look like 1.4.0, the last release without these two."""
    monkeypatch.setattr(mcap, "__version__", "1.4.0")
    monkeypatch.delattr(Writer, "flush")
    monkeypatch.delattr(MessageEncoding, "MessagePack")


TOO_OLD = ("the installed mcap 1.4.0 has no Writer.flush, MessageEncoding.MessagePack, which the recorder uses: "
           "install mcap>=1.5.0 (pip install 'mcap>=1.5.0')")


def test_a_too_old_mcap_is_named_with_the_release_needed(mcap_1_4):
    with pytest.raises(McapTooOld) as raised:
        check_mcap()
    assert str(raised.value) == TOO_OLD


def test_the_recorder_says_so_at_start_and_opens_no_session(mcap_1_4, tmp_path, caplog):
    with caplog.at_level(logging.ERROR):
        code = recorder_box.main(None, ["main"], [], "recorder", tmp_path / "run", 1.0, 1.0, 0.5)
    assert code == 2
    assert TOO_OLD in caplog.text
    assert not (tmp_path / "run").exists()
