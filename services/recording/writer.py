"""Bus samples into MCAP files: one channel per key (its topic), msgpack messages, each payload class's
JSON Schema in the file, zstd chunks with message indexes. A file is rotated by size or age, and its
chunk in progress is finished every `flush_s`, so a recorder killed outright loses at most that long."""
from __future__ import annotations

import json
import re
import time
from collections.abc import Callable
from pathlib import Path

import mcap
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, IndexType, Writer

from bus_schema.catalog import json_schema

PROFILE = "dogged"  # the MCAP header's profile: files written by this recorder
_NAME = "{name}-{index:04d}-{stamp}.mcap"

# what the recorder uses of mcap (here and in reader.repair); Writer.flush and MessageEncoding.MessagePack
# came in mcap 1.5.0, the floor pyproject.toml asks for
MCAP_NEEDED = "1.5.0"
MCAP_USES = {Writer: ("start", "add_metadata", "register_schema", "register_channel", "add_message", "flush",
                      "finish"),
             MessageEncoding: ("MessagePack",), SchemaEncoding: ("JSONSchema",), CompressionType: ("ZSTD",),
             IndexType: ("CHUNK", "MESSAGE", "METADATA")}
# The summary's indexes: no attachment's (none is written). mcap's Writer gives every group it indexes a summary
# offset, an empty one too, and an offset to no record is an error to `mcap doctor` (pymcap-cli's:
# SUMMARY_OFFSET_WITHOUT_GROUP; every recorded file had one, for the attachments). A file the recorder writes
# holds a message (it opens at the first) and a metadata record (`recorder`, written first), so none is empty.
INDEXES = IndexType.CHUNK | IndexType.MESSAGE | IndexType.METADATA


def mcap_writer(stream, library: str, summary_offsets: bool = True, chunk_size: int = 1 << 20) -> Writer:
    """mcap's Writer as every file of ours is written (zstd chunks, INDEXES), started: `summary_offsets` only
    where no indexed group can be empty."""
    writer = Writer(stream, chunk_size=chunk_size, compression=CompressionType.ZSTD, index_types=INDEXES,
                    use_summary_offsets=summary_offsets)
    writer.start(profile=PROFILE, library=library)
    return writer


class McapTooOld(RuntimeError):
    """The installed mcap lacks something the recorder uses."""


def check_mcap() -> None:
    """Raises McapTooOld, naming the release needed, if the installed mcap lacks something the recorder
    uses (without this, it would fail at its first write or flush with an AttributeError, again at each
    restart)."""
    missing = [f"{owner.__name__}.{name}" for owner, names in MCAP_USES.items() for name in names
               if not hasattr(owner, name)]
    if missing:
        raise McapTooOld(f"the installed mcap {mcap.__version__} has no {', '.join(missing)}, which the recorder "
                         f"uses: install mcap>={MCAP_NEEDED} (pip install 'mcap>={MCAP_NEEDED}')")


def file_index(path: Path, name: str) -> int | None:
    """The index of one of recorder `name`'s files (<name>-<index>-<stamp>.mcap), else None."""
    match = re.fullmatch(rf"{re.escape(name)}-(\d{{4,}})-[0-9T-]+\.mcap", path.name)
    return int(match.group(1)) if match else None


class RunWriter:
    """MCAP files `<name>-<index>-<stamp>.mcap` in `folder`; indexes continue after the files already there
    (a restarted recorder adds to its run). `open_file` opens a path for binary writing (tests inject
    failures); OSError from it or from writing is the caller's to report."""

    def __init__(self, folder: Path, name: str, rotate_bytes: int, rotate_s: float, flush_s: float = 0.5,
                 open_file: Callable = open):
        self.folder, self.name = Path(folder), name
        self.rotate_bytes, self.rotate_s, self.flush_s, self.open_file = rotate_bytes, rotate_s, flush_s, open_file
        self.metadata: dict[str, dict[str, str]] = {}  # written into every file
        self.path: Path | None = None
        self.files_written, self.messages = 0, 0
        self.pending = 0  # messages written since the last flush: what a failure now loses
        self.abandoned: list[Path] = []  # files given up on after a failed write, left unfinished (see abandon)
        self._writer = self._stream = None
        self._schemas: dict[type, int] = {}
        self._channels: dict[str, int] = {}
        self._sequence: dict[str, int] = {}
        self._opened = self._flushed = 0.0

    def next_path(self) -> Path:
        indexes = [i for p in self.folder.glob(f"{self.name}-*.mcap") if (i := file_index(p, self.name)) is not None]
        stamp = time.strftime("%Y%m%dT%H%M%S", time.gmtime())
        return self.folder / _NAME.format(name=self.name, index=max(indexes, default=-1) + 1, stamp=stamp)

    def _open(self) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        path = self.next_path()
        self._stream = self.open_file(path, "wb")
        self.path = path  # before anything is written: a file whose header a full disk refused is this one
        self._writer = mcap_writer(self._stream, "dogged recorder")
        self._writer.add_metadata("recorder", {"name": self.name, "file": path.name})
        self._schemas, self._channels, self._sequence = {}, {}, {}
        self._opened = self._flushed = time.monotonic()
        self.files_written += 1
        for name, data in self.metadata.items():
            self._writer.add_metadata(name, data)

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Kept and written into this file and every later one (spaces, the run's description)."""
        self.metadata[name] = data
        if self._writer is not None:
            self._writer.add_metadata(name, data)

    def write(self, key: str, cls: type, raw: bytes, log_ns: int, publish_ns: int) -> None:
        if self._writer is None:
            self._open()
        channel = self._channels.get(key)
        if channel is None:
            schema = self._schemas.get(cls)
            if schema is None:
                schema = self._schemas[cls] = self._writer.register_schema(
                    f"dogged.{cls.__name__}", SchemaEncoding.JSONSchema, json.dumps(json_schema(cls)).encode())
            channel = self._channels[key] = self._writer.register_channel(key, MessageEncoding.MessagePack, schema)
        sequence = self._sequence[key] = self._sequence.get(key, 0) + 1
        self._writer.add_message(channel, log_time=log_ns, data=raw, publish_time=publish_ns, sequence=sequence)
        self.messages += 1
        self.pending += 1

    def upkeep(self) -> bool:
        """Call often: finishes the chunk in progress every flush_s, rotates when the file is big or old.
        True when a chunk went to the file (so the disk takes writes)."""
        if self._writer is None:
            return False
        now, flushed = time.monotonic(), False
        if now - self._flushed >= self.flush_s:
            self._writer.flush()
            self._stream.flush()
            self._flushed, self.pending, flushed = now, 0, True
        if self._stream.tell() >= self.rotate_bytes or now - self._opened >= self.rotate_s:
            self.close()
        return flushed

    @property
    def bytes_in_file(self) -> int:
        return self._stream.tell() if self._stream is not None else 0

    def abandon(self) -> int:
        """After a write failed (a full disk): drop the file as it is, unfinished, noted in `abandoned` (the
        reader and `repair` take what it holds); the next write opens another. Returns the messages lost
        (those since the last flush)."""
        stream, self._writer, self._stream = self._stream, None, None
        lost, self.pending = self.pending, 0
        if stream is not None and self.path is not None:
            self.abandoned.append(self.path)
        try:
            if stream is not None:
                stream.close()
        except OSError:
            pass
        return lost

    def close(self) -> None:
        """Finishes the file (summary, indexes, footer); the next write opens another."""
        writer, stream, self._writer, self._stream = self._writer, self._stream, None, None
        if writer is None:
            return
        try:
            writer.finish()
            self.pending = 0
        finally:
            stream.close()
