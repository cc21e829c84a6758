"""A recorded run read back: its MCAP files in order, each sample's key, times and raw payload, and the
run's metadata. A file its recorder could not finish (killed, a full disk) reads up to its last whole
chunk; `repair` rewrites such a file as a finished one (summary, indexes), as `mcap recover` would."""
from __future__ import annotations

import json
import os
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.well_known import MessageEncoding

from bus_schema import SchemaError, decode
from bus_schema.catalog import payload_of
from services.recording.writer import mcap_writer

MAGIC = b"\x89MCAP0\r\n"


@dataclass(frozen=True, slots=True)
class Sample:
    key: str
    log_ns: int      # when the recorder received it (its wall clock)
    publish_ns: int  # the sender's stamp where the payload has one, else log_ns
    raw: bytes

    def decoded(self):
        """The payload as its bus_schema class (SchemaError if it does not decode)."""
        found = payload_of(self.key)
        if found is None:
            raise SchemaError(self.key, "*", "not a key the bus publishes on")
        return decode(found[0], self.raw, self.key)


def run_files(run: str | Path) -> list[Path]:
    """A run's MCAP files in the order they were written: a folder's *.mcap by name, or one file."""
    run = Path(run)
    if run.is_file():
        return [run]
    files = sorted(run.glob("*.mcap"))
    if not files:
        raise FileNotFoundError(f"{run}: no .mcap files (a run is a recorder's folder, or one of its files)")
    return files


def is_finished(path: Path) -> bool:
    """Whether a file ends with MCAP's closing magic (its recorder finished it)."""
    size = path.stat().st_size
    if size < len(MAGIC) * 2:
        return False
    with open(path, "rb") as f:
        f.seek(size - len(MAGIC))
        return f.read() == MAGIC


def _records(path: Path, truncated: list) -> Iterator:
    """Every record of the file, chunks opened; stops at a cut-off tail (noted in `truncated`)."""
    with open(path, "rb") as f:
        try:
            yield from StreamReader(f, validate_crcs=True).records
        except (McapError, ValueError, EOFError, struct.error) as err:  # a cut record, a chunk half written
            truncated.append((path, f"{type(err).__name__}: {err}"))


def iter_samples(run: str | Path, keys: set[str] | None = None, truncated: list | None = None) -> Iterator[Sample]:
    """Every sample of the run (only `keys` if given), in the order the recorder received them."""
    truncated = [] if truncated is None else truncated
    for path in run_files(run):
        channels: dict[int, str] = {}
        for record in _records(path, truncated):
            if isinstance(record, Channel):
                channels[record.id] = record.topic
            elif isinstance(record, Message):
                key = channels[record.channel_id]
                if keys is None or key in keys:
                    yield Sample(key, record.log_time, record.publish_time, record.data)


def read_metadata(run: str | Path) -> dict[str, dict[str, str]]:
    """The run's metadata by name (the first file that has a name wins): spaces, the run's description."""
    found: dict[str, dict[str, str]] = {}
    for path in run_files(run):
        if is_finished(path):  # the summary indexes it: no chunk is read
            with open(path, "rb") as f:
                records = list(make_reader(f).iter_metadata())
        else:
            records = [r for r in _records(path, []) if isinstance(r, Metadata)]
        for record in records:
            found.setdefault(record.name, dict(record.metadata))
    return found


def spaces_in(metadata: dict, instance: str) -> dict | None:
    """The spaces (Spaces.to_dict) recorded for an instance, if the recorder got them."""
    entry = metadata.get(f"spaces dl/{instance}")
    return json.loads(entry["spaces"]) if entry else None


def repair(path: Path, metadata: dict[str, dict[str, str]] | None = None) -> int:
    """Rewrite an unfinished file as a finished one holding every whole record, and each of `metadata` (name:
    record) it lacks (what its recorder learned after the file was cut: the spaces); returns its messages."""
    tmp = path.with_suffix(".repairing")
    try:
        count = _rewrite(path, tmp, metadata or {})
    except BaseException:  # (a disk still full): no half-written copy left beside the file
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, path)
    return count


def _rewrite(path: Path, tmp: Path, metadata: dict[str, dict[str, str]]) -> int:
    """Every whole record of `path` and each of `metadata` it lacks into a finished file `tmp`; returns its
    messages."""
    named: set[str] = set()
    schemas: dict[int, int] = {}
    channels: dict[int, int] = {}
    count = 0
    with open(tmp, "wb") as out:
        # no summary offsets: a file cut before its first message or metadata record leaves those groups empty
        writer = mcap_writer(out, "dogged recorder (repaired)", summary_offsets=False)
        for record in _records(path, []):
            if isinstance(record, Schema):
                schemas[record.id] = writer.register_schema(record.name, record.encoding, record.data)
            elif isinstance(record, Channel):
                channels[record.id] = writer.register_channel(record.topic, record.message_encoding or
                                                              MessageEncoding.MessagePack,
                                                              schemas.get(record.schema_id, 0), record.metadata)
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, dict(record.metadata))
                named.add(record.name)
            elif isinstance(record, Message) and record.channel_id in channels:
                writer.add_message(channels[record.channel_id], record.log_time, record.data, record.publish_time,
                                   record.sequence)
                count += 1
        for name, data in metadata.items():
            if name not in named:
                writer.add_metadata(name, data)
        writer.finish()
        out.flush()
        os.fsync(out.fileno())
    return count
