"""A soaked run's recordings checked once the profile has stopped: every file passes an MCAP doctor (mcap's own
CLI where it is installed, else pymcap-cli's, which the test extra installs), opens whole in mcap's own Python
reader (as tests/test_recorder_mcap.py reads them) and in `dogged replay`, alone and as the whole run; which
stretches of the run are missing from them outside the faults."""
from __future__ import annotations

import contextlib
import io
import json
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from mcap.reader import make_reader

from services.replay.cli import replay_main
from services.recording.reader import is_finished


@dataclass
class FileCheck:
    name: str
    mb: float
    finished: bool            # its recorder finished it (MCAP's closing magic)
    opens: bool               # an MCAP doctor found no error or warning, and mcap's reader read it whole
    messages: int
    replays: bool             # `dogged replay FILE` exited 0
    said: str = ""            # why not, when it does not


@dataclass
class RecordingsCheck:
    files: list[FileCheck] = field(default_factory=list)
    run_replays: bool = False  # `dogged replay` of the run's folder
    run_said: str = ""
    reader: str = ""           # the doctor and reader that read them

    @property
    def all_open(self) -> bool:
        return bool(self.files) and all(f.opens and f.replays for f in self.files) and self.run_replays


def doctor_command() -> tuple[list[str], str] | None:
    """The MCAP doctor to run and its name: mcap's CLI where it is on PATH, else pymcap-cli's beside this Python
    (or on PATH); None where neither is."""
    if cli := shutil.which("mcap"):
        return [cli, "doctor"], "mcap CLI doctor"
    beside = Path(sys.executable).with_name("pymcap-cli")
    if cli := (str(beside) if beside.exists() else shutil.which("pymcap-cli")):
        return [cli, "doctor", "--format", "jsonl"], "pymcap-cli doctor"
    return None


def doctor(path: Path, found: tuple[list[str], str] | None = None) -> tuple[bool, list[dict], str]:
    """(passed, the findings worse than info where the doctor lists them, its last words) for one file, by the
    doctor `found` (doctor_command's, looked up here if not given)."""
    command = (found or doctor_command() or ([], ""))[0]
    if not command:
        return False, [], "no MCAP doctor installed (pip install pymcap-cli)"
    done = subprocess.run([*command, str(path)], capture_output=True, text=True, timeout=300)
    lines = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    findings = [line for line in lines if line.get("type") == "finding" and line.get("severity") != "info"]
    said = "; ".join(f"{f.get('severity')} {f.get('code')}: {f.get('message')}" for f in findings) or \
        (done.stdout + done.stderr).strip()
    return done.returncode == 0 and not findings, findings, said[-300:]


def opens_in_mcap(path: Path, found: tuple[list[str], str] | None = None) -> tuple[bool, int, str]:
    """(opens, messages, why not): the doctor (`found`, see doctor) passes it and mcap's own reader reads it whole
    (its summary, then every message)."""
    passed, _, said = doctor(path, found)
    if not passed:
        return False, 0, f"doctor: {said}"
    try:
        with open(path, "rb") as f:
            return True, sum(1 for _ in make_reader(f).iter_messages()), ""
    except Exception as err:  # noqa: BLE001 - whatever mcap raises, the file does not open
        return False, 0, f"{type(err).__name__}: {err}"[:300]


def replays(run: Path, scratch: Path) -> tuple[bool, str]:
    """`dogged replay RUN` (its default learner), in this process: whether it exited 0, and its last words."""
    said = io.StringIO()
    with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
        try:
            code = replay_main([str(run), "--plot", str(scratch / "compare.png")])
        except Exception as err:  # noqa: BLE001 - a replay that raises does not open the file
            code, _ = 1, said.write(f"{type(err).__name__}: {err}")
    return code == 0, said.getvalue().strip().splitlines()[-1][:300] if said.getvalue().strip() else ""


def check(folder: Path, scratch: Path) -> RecordingsCheck:
    scratch.mkdir(parents=True, exist_ok=True)
    found = doctor_command()  # (once for every file)
    out = RecordingsCheck(reader=f"{found[1] if found else 'no doctor'} and mcap's Python reader")
    for path in sorted(folder.glob("*.mcap")):
        opens, messages, why = opens_in_mcap(path, found)
        replayed, said = replays(path, scratch)
        out.files.append(FileCheck(path.name, round(path.stat().st_size / 1e6, 3), is_finished(path), opens, messages,
                                   replayed, why if not opens else said if not replayed else ""))
    out.run_replays, out.run_said = replays(folder, scratch)
    return out


def missing_stretches(observed: np.ndarray, recorded: np.ndarray, faults: list[tuple[float, float]],
                      period: float) -> dict:
    """Of the inputs the run published (their stamps, as an observer saw them), the stretches whose every
    input is missing from the recording: the longest outside every fault window (its seconds, and the stamp
    it begins at), and the longest inside one; a stretch of n inputs lasts n periods."""
    observed = np.unique(observed)
    missing = ~np.isin(observed, recorded)
    out = {"outside_s": 0.0, "outside_at": None, "inside_s": 0.0}
    i = 0
    while i < len(observed):
        if not missing[i]:
            i += 1
            continue
        j = i
        while j + 1 < len(observed) and missing[j + 1]:
            j += 1
        first, last = observed[i], observed[j]
        seconds = round(float(last - first) + period, 3)
        if any(start <= last and first <= end for start, end in faults):
            out["inside_s"] = max(out["inside_s"], seconds)
        elif seconds > out["outside_s"]:
            out["outside_s"], out["outside_at"] = seconds, float(first)
        i = j + 1
    return out
