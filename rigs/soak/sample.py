"""Each minute's figures of a soaking profile: every process's resident memory and open file descriptors
(from /proc: a service with the processes it spawned, as the GP's fitting processes), the disk its
recordings, logs and state take, and the pairs held in each place (a pair log, a recording: counted as they
grow, each file read once more only when it changed)."""
from __future__ import annotations

import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import msgpack
import numpy as np

from bus_schema import InstanceKeys
from services.recording.reader import iter_samples


TICK_S = 1.0 / os.sysconf("SC_CLK_TCK")


@dataclass(frozen=True)
class Proc:
    pid: int
    rss_mb: float  # the process and its descendants
    fds: int       # likewise
    processes: int
    cpu_s: float   # CPU time (user and system) the process and its live descendants have had


def _children() -> dict[int, list[int]]:
    out: dict[int, list[int]] = {}
    for entry in os.scandir("/proc"):
        if entry.name.isdigit():
            try:
                ppid = int(Path(entry.path, "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            out.setdefault(ppid, []).append(int(entry.name))
    return out


def _cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) * TICK_S


def _rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return 0.0  # a zombie


def proc_tree(pid: int, children: dict[int, list[int]], apart: set[int] = frozenset()) -> Proc | None:
    """The process `pid` and its descendants (but those in `apart`, and theirs), or None when it is gone."""
    pids, i = [pid], 0
    while i < len(pids):
        pids += [c for c in children.get(pids[i], []) if c not in apart]
        i += 1
    rss = fds = cpu = 0.0
    for p in pids:
        try:
            rss += _rss_mb(p)
            fds += len(os.listdir(f"/proc/{p}/fd"))
            cpu += _cpu_s(p)
        except (FileNotFoundError, ProcessLookupError):  # gone meanwhile: a child is left out, the process is gone
            if p == pid:
                return None
    return Proc(pid, round(rss, 2), int(fds), len(pids), round(cpu, 2))


def service_pids(supervisor: int) -> dict[str, int]:
    """The supervisor's services by name (`--name`; the router has none), read from /proc: `dogged ps` asks the
    router, which may be the service just killed."""
    out = {}
    for pid in _children().get(supervisor, []):
        try:
            argv = Path(f"/proc/{pid}/cmdline").read_bytes().decode(errors="replace").split("\0")
        except OSError:
            continue
        if "run" in argv:
            box = argv[argv.index("run") + 1] if argv.index("run") + 1 < len(argv) else "?"
            out[argv[argv.index("--name") + 1] if "--name" in argv[:-1] else box] = pid
    return out


def page_pid() -> int | None:
    """The process of this one that drives the page's browser (Playwright's driver; chromium below it)."""
    for pid in _children().get(os.getpid(), []):
        try:
            if b"playwright" in Path(f"/proc/{pid}/cmdline").read_bytes():
                return pid
        except OSError:
            continue
    return None


def procs(pids: dict[str, int]) -> dict[str, Proc]:
    """Each named process with its descendants (the supervisor's are the services: each its own), those alive."""
    children, roots = _children(), set(pids.values())
    found = {name: proc_tree(pid, children, roots) for name, pid in pids.items() if pid}
    return {name: p for name, p in found.items() if p is not None}


def folder_mb(folder: Path) -> float:
    if not folder.is_dir():
        return 0.0
    return sum(f.stat().st_size for f in folder.rglob("*") if f.is_file()) / 1e6


def disk_used_mb(folder: Path) -> float:
    """What the filesystem holding `folder` has in use (a small one filled on purpose shows it)."""
    usage = shutil.disk_usage(folder)
    return (usage.total - usage.free) / 1e6


class PairLogCount:
    """The records in a learner's pair log, counted as the file grows (a cut last record waits)."""

    def __init__(self):
        self._read: dict[Path, tuple[int, msgpack.Unpacker, int]] = {}  # path -> (bytes read, unpacker, records)

    def __call__(self, path: Path) -> int:
        offset, unpacker, count = self._read.get(path) or (0, msgpack.Unpacker(raw=False), 0)
        try:
            with open(path, "rb") as f:
                f.seek(offset)
                more = f.read()
        except FileNotFoundError:
            return 0
        unpacker.feed(more)
        count += sum(1 for _ in unpacker)
        self._read[path] = (offset + len(more), unpacker, count)
        return count


@dataclass
class RecordedSoFar:
    """What a run's recordings hold: the training pairs by (epoch, seq) and the inputs' stamps; each file
    read again only when its size changed."""
    folder: Path
    keys: InstanceKeys
    _files: dict = field(default_factory=dict)  # path -> (size, pairs, stamps)

    def update(self) -> None:
        wanted = {self.keys.train, self.keys.input}
        for path in sorted(self.folder.glob("*.mcap")) if self.folder.is_dir() else []:
            size = path.stat().st_size
            if path in self._files and self._files[path][0] == size:
                continue
            pairs, stamps = set(), []
            for sample in iter_samples(path, wanted, truncated=[]):
                try:
                    msg = sample.decoded()
                except ValueError:
                    continue
                if sample.key == self.keys.train:
                    pairs.add((msg.epoch, msg.seq))
                else:
                    stamps.append(msg.stamp)
            self._files[path] = (size, pairs, np.array(stamps))
        for gone in [p for p in self._files if not p.exists()]:
            del self._files[gone]

    def pairs(self) -> set:
        return set().union(*(pairs for _, pairs, _ in self._files.values()))

    def stamps(self) -> np.ndarray:
        parts = [stamps for _, _, stamps in self._files.values()]
        return np.unique(np.concatenate(parts)) if parts else np.array([])
