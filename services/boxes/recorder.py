"""The recorder: every sample of the instances and robots it is given, into MCAP files (services.recording).

Each payload is checked against the bus schema before it is written (one that does not decode is
counted and logged, not recorded); the platform's spaces go into every file as metadata. A folder it
cannot write (unwritable, a full disk) is an error in its status (`dogged ps`) and its log: it keeps
running, counts what it could not record, and tries a new file every few seconds; the loop never
waits for it. Once the disk takes writes again, the files it had to leave unfinished are finished (or
removed, when they hold no message), so every file of the run opens in mcap's readers. A person may
pause it and resume it (`dl/<i>/record`, the page's Record switch): paused, it counts what it does not
write; the switches themselves are recorded, so a file says why it has a gap.
What waits to be written is bounded (`--inbox-mb`): past it, samples are dropped on arrival and counted
(`inbox_dropped`), so a flood or a stalled disk costs those samples, not the process. On a stop, what
had arrived is written before the file is finished.
Inputs are a sensor stream (the platform never waits for a slow subscriber): one that never reached the recorder
shows as a tick skipped, counted (`inputs_missed`) and logged; a jump past MISSED_AT_MOST ticks is counted as a
jump (`input_tick_jumps`: a platform restarted elsewhere, a forged tick), not as that many inputs missed.
"""
from __future__ import annotations

import argparse
import collections
import itertools
import json
import socket
import time
from pathlib import Path

import zenoh

from bus_schema import Input, InstanceKeys, RecordSwitch, RobotKeys, SchemaError, Spaces, SpacesMessage, decode
from bus_schema.catalog import payload_of
from services.bus.config import add_bus_args, config_from_args
from services.bus.inbox import Rejects
from services.boxes.numbers import number
from services.bus.lifecycle import setup_logging
from services.bus.runtime import BoxRuntime
from services.recording.reader import is_finished, repair
from services.recording.writer import McapTooOld, RunWriter, check_mcap, file_index

RETRY_S = 5.0  # after a write failed, how long before a new file is tried
MISSED_AT_MOST = 1000  # ticks skipped at once that can be inputs missed (33 s at 30 Hz); past it, a jump
MISSED_LOG_S = 10.0  # inputs missed and jumps are logged at most this often, with the totals so far


class Recording:
    """The recorder's state, driven by samples (bus-free: tests hand it samples and fail its files). Its
    rejects and counters are its box's (the status says them), or its own without one."""

    def __init__(self, writer: RunWriter, log, name: str = "recorder", box: BoxRuntime | None = None):
        self.writer, self.log, self.name = writer, log, name
        self.paused = False  # a person paused it (dl/<i>/record): samples are counted, not written
        self.rejects, self.counts = (box.rejects, box.counts) if box else (Rejects(log), collections.Counter())
        self.error, self._retry_at = "", 0.0
        self.dims: dict[str, dict] = {}  # dl/<instance> -> the vector lengths its spaces give (once known)
        self._last_tick: dict[str, int] = {}  # input key -> the tick of the last input received
        self._missed_logged_at = -MISSED_LOG_S

    def on_sample(self, key: str, raw: bytes, log_ns: int) -> None:
        found = payload_of(key)
        if found is None:
            self.counts["unknown_keys"] += 1  # liveliness and queries carry no sample; anything else is news
            return
        try:  # as strictly as the services that read it: vector lengths too, once the spaces are known
            msg = decode(found[0], raw, key, self.dims.get(key[:key.find("/", 3)]))
        except SchemaError as err:
            self.rejects(key, err)
            return
        if isinstance(msg, Input):
            self.note_tick(key, msg.tick)
        if isinstance(msg, RecordSwitch):  # every switch is recorded: the file says why it has a gap
            if msg.recorder in ("", self.name) and self.paused == msg.on:
                self.log.info("recording %s by a person's switch", "resumed" if msg.on else "paused")
                self.paused = not msg.on
        elif self.paused:
            self.counts["paused_samples"] += 1
            return
        stamp = getattr(msg, "stamp", None)
        publish_ns = int(stamp * 1e9) if isinstance(stamp, float) and stamp > 0 else log_ns
        if self.error and time.monotonic() < self._retry_at:
            self.counts["not_recorded"] += 1
            return
        try:
            self.writer.write(key, found[0], raw, log_ns, publish_ns)
        except OSError as err:
            self.failed(err)
            self.counts["not_recorded"] += 1
            return
        if self.error:
            self.log.info("recording again, into %s", self.writer.path)
            self.error = ""
        self.counts["recorded"] += 1

    def note_tick(self, key: str, tick: int) -> None:
        """Ticks skipped since the last input on `key` are inputs that never arrived (a tick not past the last
        is a platform restarted, which counts from 1 again: nothing is missed)."""
        last, self._last_tick[key] = self._last_tick.get(key), tick
        skipped = tick - last - 1 if last is not None else 0
        if skipped <= 0:
            return
        jump = skipped > MISSED_AT_MOST
        counter = "input_tick_jumps" if jump else "inputs_missed"
        self.counts[counter] += 1 if jump else skipped
        if time.monotonic() - self._missed_logged_at < MISSED_LOG_S:
            return  # (a stranger's ticks, back and forth, must not flood the log)
        self._missed_logged_at = time.monotonic()
        what, meaning = ((f"tick {tick} after {last}: a jump of {skipped + 1} ticks", "not counted as inputs missed")
                         if jump else (f"{skipped} input(s) never arrived before tick {tick}", "not in the recording"))
        self.log.warning("%s: %s (%d so far): %s", key, what, self.counts[counter], meaning)

    def on_spaces(self, key: str, raw: bytes) -> None:
        """The first answer is recorded and its vector lengths checked from then on; an answer that
        contradicts it (without access control anyone may answer) makes the lengths unchecked again, as
        fetch_spaces trusts no answer another contradicts: a stranger cannot make the run go unrecorded."""
        prefix = key.rsplit("/", 1)[0]
        name = f"spaces {prefix}"
        known = self.writer.metadata.get(name)
        try:
            spaces = decode(SpacesMessage, raw, key).spaces
            parsed = Spaces.from_dict(spaces)
        except (SchemaError, KeyError, TypeError, ValueError) as err:
            if known is None:  # (once known, an answer that is no spaces changes nothing)
                self.rejects(key, err)
            return
        if known is None:
            try:  # (kept by the writer even when this file cannot take it: every next file gets it)
                self.writer.add_metadata(name, {"spaces": json.dumps(spaces)})
            except OSError as err:
                self.failed(err)
            if prefix.startswith("dl/"):
                self.dims[prefix] = {"x": parsed.input.dims, "y": parsed.output.dims}
        elif known["spaces"] != json.dumps(spaces) and self.dims.pop(prefix, None) is not None:
            self.rejects(key, ValueError(f"two different answers on {key}: vector lengths no longer checked"))

    def upkeep(self) -> None:
        try:
            wrote = self.writer.upkeep()
        except OSError as err:
            self.failed(err)
            return
        if wrote and self.writer.abandoned:  # the disk takes writes again: the files it cut are finished now
            self.writer.abandoned = [p for p in self.writer.abandoned
                                     if not finish_cut(p, self.log, self.writer.metadata)]

    def failed(self, err: OSError) -> None:
        where = self.writer.path or self.writer.folder
        error = f"cannot write {where}: {err.strerror or err}"
        lost = self.writer.abandon()  # what was written since the last flush is not on disk
        self.counts["recorded"] -= lost
        self.counts["not_recorded"] += lost
        if error != self.error:  # once per kind of failure, not once per retry
            self.log.error("%s; the loop goes on unrecorded; trying a new file every %g s", error, RETRY_S)
        self.error, self._retry_at = error, time.monotonic() + RETRY_S
        self.counts["write_errors"] += 1

    def report(self):
        counters = {"files": self.writer.files_written, "file_bytes": self.writer.bytes_in_file}
        return counters, {"folder": str(self.writer.folder), "file": str(self.writer.path or ""), "error": self.error,
                          "recording": not self.paused}


def finish_cut(path: Path, log, metadata: dict | None = None) -> bool:
    """A file left unfinished (a kill, a full disk) rewritten as a finished one, with the run's `metadata` it
    lacks (spaces that came after it was cut: without them it would not replay alone), or removed if it holds
    no message (a new file a full disk let the recorder open, but not write). False if that failed (the disk
    is still full, say): it is left as it is, for later."""
    try:
        messages = repair(path, metadata)
        if messages == 0:
            path.unlink()
            log.info("removed %s (left unfinished, with no message in it)", path)
        else:
            log.info("repaired %s (left unfinished): %d messages", path, messages)
        return True
    except OSError as err:
        log.error("could not repair %s: %s", path, err)
        return False


def repair_unfinished(writer: RunWriter, log) -> None:
    """This recorder's files a killed run left unfinished (in the writer's folder), rewritten as finished
    ones; those it cannot rewrite yet (a full disk) are the writer's abandoned files, finished once the disk
    takes writes again (Recording.upkeep)."""
    if not writer.folder.is_dir():
        return
    for path in sorted(writer.folder.glob(f"{writer.name}-*.mcap")):
        if file_index(path, writer.name) is not None and not is_finished(path) and not finish_cut(path, log):
            writer.abandoned.append(path)


def ask_spaces(box: BoxRuntime, keys: list[str]) -> None:
    """Ask each spaces queryable; answers come into the inbox as ('spaces', key, payload)."""
    def on_reply(reply):
        if reply.ok is not None:
            box.inbox.put(("spaces", str(reply.ok.key_expr), reply.ok.payload.to_bytes(), None))
    for key in keys:
        box.session.get(key, on_reply, timeout=2.0)


def take(recording: Recording, items) -> None:
    for tag, key, raw, log_ns in items:
        if tag == "sample":
            recording.on_sample(key, raw, log_ns)
        else:
            recording.on_spaces(key, raw)


def main(conf: zenoh.Config, instances: list[str], robots: list[str], name: str, out: Path, rotate_mb: float,
         rotate_min: float, flush_s: float, inbox_mb: float = 256.0) -> int:
    try:
        check_mcap()
    except McapTooOld as err:  # said before any session, signal handler or file
        setup_logging("recorder", name).error("%s", err)
        return 2
    box = BoxRuntime(conf, InstanceKeys(instances[0]), "recorder", name, inbox_bytes=int(inbox_mb * 2**20))
    writer = RunWriter(out, name, int(rotate_mb * 1e6), rotate_min * 60.0, flush_s)
    repair_unfinished(writer, box.log)
    writer.add_metadata("run", {"instances": ",".join(instances), "robots": ",".join(robots),
                                "host": socket.gethostname(), "started": time.strftime("%Y-%m-%dT%H:%M:%SZ",
                                                                                       time.gmtime())})
    recording = Recording(writer, box.log, name, box)
    spaces_keys = [InstanceKeys(i).spaces for i in instances] + [RobotKeys(r).spaces for r in robots]
    with box:
        for prefix in [InstanceKeys(i).prefix for i in instances] + [RobotKeys(r).prefix for r in robots]:
            box.subscribe(f"{prefix}/**", "sample", stamped=True)  # stamped on arrival: the log time
        box.log.info("recording %s into %s", ", ".join([f"dl/{i}" for i in instances] + [f"robot/{r}" for r in robots]),
                     out)
        asked = 0.0
        for batch in box.batches(0.05, recording.report):
            if time.monotonic() - asked > 2.0 and any(f"spaces {k.rsplit('/', 1)[0]}" not in writer.metadata
                                                      for k in spaces_keys):
                ask_spaces(box, spaces_keys)
                asked = time.monotonic()
            take(recording, batch)
            recording.upkeep()
        take(recording, itertools.islice(box.inbox.drain(0.0), box.inbox.waiting))  # what came before the stop
        try:
            writer.close()
        except OSError as err:
            recording.failed(err)
    box.log.info("stopped: %d samples recorded in %d files", recording.counts["recorded"], writer.files_written)
    return 0


def arg_parser() -> argparse.ArgumentParser:
    """The one reading of `dogged run recorder`'s arguments (a profile's are read with it too)."""
    parser = argparse.ArgumentParser(prog="dogged run recorder", description=__doc__.splitlines()[0])
    parser.add_argument("--instance", action="append", default=None, help="a DL instance to record (repeatable)")
    parser.add_argument("--robot", action="append", default=[], help="a robot's streams to record (repeatable)")
    parser.add_argument("--name", default="recorder")
    parser.add_argument("--out", required=True, help="the run's folder: MCAP files go here")
    parser.add_argument("--rotate-mb", type=number(above=0.0), default=512.0, help="start a new file past this size")
    parser.add_argument("--rotate-min", type=number(above=0.0), default=30.0, help="start a new file after this long")
    parser.add_argument("--flush-s", type=number(above=0.0, at_most=1.0), default=0.5,
                        help="finish the chunk in progress this often (what a kill can lose)")
    parser.add_argument("--inbox-mb", type=number(at_least=1.0, at_most=65536.0), default=256.0,
                        help="what may wait to be written (a stalled disk, a flood); past it, samples are "
                             "dropped on arrival and counted as inbox_dropped")
    add_bus_args(parser)
    return parser


def cli(argv=None) -> int:
    parser = arg_parser()
    a = parser.parse_args(argv)
    instances = list(dict.fromkeys(a.instance or ["main"]))
    return main(config_from_args(a), instances, list(dict.fromkeys(a.robot)), a.name, Path(a.out), a.rotate_mb,
                a.rotate_min, a.flush_s, a.inbox_mb)
