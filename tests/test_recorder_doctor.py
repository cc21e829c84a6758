"""Every file the recorder writes, and every one it repairs, passes an MCAP doctor (issue 31: every recording
opens in the mcap CLI): pymcap-cli's `doctor`, which reads the file against the MCAP specification with a
parser of its own (not mcap's), run as the command a person would run, finding no error and no warning.
Before, every recorded file had one error: a summary offset to an empty group (the attachments' index)."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

from bus_schema import Input, encode
from rigs.soak.records import doctor, doctor_command
from services.recording.reader import MAGIC, repair
from services.recording.writer import RunWriter

pytestmark = pytest.mark.live  # the doctor is a process

DOCTOR = Path(sys.executable).with_name("pymcap-cli")


def test_the_soak_has_a_doctor_where_mcap_s_own_cli_is_not_installed():
    assert DOCTOR.exists(), "pip install -e '.[test]' installs pymcap-cli"
    assert doctor_command() is not None


def doctor_says(path: Path) -> tuple[list[dict], dict]:
    """pymcap-cli doctor's findings worse than info, and its summary line."""
    done = subprocess.run([str(DOCTOR), "doctor", "--format", "jsonl", str(path)], capture_output=True, text=True,
                          timeout=120)
    lines = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    summary = [line for line in lines if line["type"] == "summary"]
    assert summary, done.stdout + done.stderr
    passed, findings, said = doctor(path)  # the soak's reading of it (rigs/soak/records.py)
    assert passed == (done.returncode == 0) == (not findings), said
    return findings, summary[0]


def write(folder: Path, messages: int, metadata: bool = True) -> RunWriter:
    run = RunWriter(folder, "recorder", rotate_bytes=10**9, rotate_s=3600.0, flush_s=0.0)
    if metadata:
        run.add_metadata("spaces dl/main", {"spaces": json.dumps({"input": 2})})
    for i in range(messages):
        run.write("dl/main/input", Input, encode(Input(i + 1, 1e9, [0.0, float(i)])), 10**18 + i, 10**18 + i)
        run.upkeep()  # (flush_s 0: each message its own chunk, as a slow stream's are)
    return run


def test_a_finished_file_has_no_error(tmp_path):
    run = write(tmp_path, 50)
    path = run.path
    run.close()
    findings, summary = doctor_says(path)
    assert findings == [] and summary["messages"] == 50 and summary["complete"]


def test_a_finished_file_without_metadata_of_the_run_has_no_error(tmp_path):
    run = write(tmp_path, 3, metadata=False)
    path = run.path
    run.close()
    assert doctor_says(path)[0] == []


@pytest.mark.parametrize("cut_at", ["after 20 chunks", "within its header", "mid-record"])
def test_a_repaired_file_has_no_error(tmp_path, cut_at):
    """A recorder killed (or its disk full) leaves a file unfinished; the next start repairs it."""
    run = write(tmp_path, 20)
    path = run.path
    run.abandon()
    data = path.read_bytes()
    if cut_at == "within its header":
        path.write_bytes(data[:len(MAGIC) + 5])
    elif cut_at == "mid-record":
        path.write_bytes(data[:len(data) - 7])
    kept = repair(path)
    findings, summary = doctor_says(path)
    assert findings == [] and summary["complete"] and summary["messages"] == kept
