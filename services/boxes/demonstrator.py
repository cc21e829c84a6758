"""The demonstrator box: runs a teacher plugin; a person switches it on and off at runtime.

While on, it answers the newest input with the teacher's output and confidence, and holds a
liveliness token dl/<i>/alive/teaching/<name> so the arbitrator waits for it; while off it is
silent. With role 'default' it is Figure 1's default controller: always answering.
"""
from __future__ import annotations

import argparse

import zenoh

from bus_schema import InstanceKeys, Input, Proposal, TeachSwitch, encode
from services.bus.config import add_bus_args, config_from_args
from services.bus.inbox import decode_or_reject
from services.bus.runtime import BoxRuntime
from services.params import parse_params
from services.teachers import TEACHERS, make_teacher


class Demonstrator:
    """The box's state: a teacher plugin, switched by the teach key, answering the newest input. Its
    role is its runtime's (teacher, or default); it declares through the runtime, so the fake bus drives it."""

    def __init__(self, box: BoxRuntime, spaces, plugin, teacher: str = ""):
        self.box, self.keys, self.plugin, self.name, self.role = box, box.keys, plugin, box.name, box.role
        self.teacher, self.log, self.rejects, self.counts = teacher, box.log, box.rejects, box.counts
        self.dims = {"x": spaces.input.dims}
        self.pub = box.sensor_publisher(self.keys.proposal(self.role, self.name))
        box.subscribe(self.keys.teach, "teach")
        self.teaching = self.listening = None

    def listen(self, on: bool) -> None:
        """A silent teacher does not even hear the inputs: no wake-up per tick for nothing."""
        if on and self.listening is None:
            self.listening = self.box.subscribe(self.keys.input, "input")
        elif not on and self.listening is not None:
            self.box.release(self.listening)
            self.listening = None

    def switch(self, on: bool) -> None:
        if on and self.teaching is None:
            # the token first: the arbitrator takes a teacher's proposals only while it holds one
            self.teaching = self.box.token(self.keys.teaching(self.name))
            self.listen(True)
            self.log.info("teaching ON")
        elif not on and self.teaching is not None:
            self.box.release(self.teaching)
            self.teaching = None
            self.listen(False)
            self.log.info("teaching OFF")

    def handle(self, batch) -> None:
        """One drained batch: switches take effect in order; only the newest input is answered."""
        newest = None
        for tag, key, raw, _ in batch:
            if tag == "teach":
                msg = decode_or_reject(TeachSwitch, raw, key, self.rejects)
                if msg is not None and msg.teacher in ("", self.name) and self.role == "teacher":
                    self.switch(msg.on)
                    self.counts["switches"] += 1
            else:
                msg = decode_or_reject(Input, raw, key, self.rejects, self.dims)
                if msg is not None:
                    self.counts["inputs"] += 1
                    newest = msg  # latest-only: a stale input is not worth answering
        if newest is not None and (self.teaching is not None or self.role == "default"):
            y, confidence = self.plugin(newest.x)
            mask = getattr(self.plugin, "mask", None) if y is not None else None
            self.pub.put(encode(Proposal(newest.tick, f"{self.role}/{self.name}", y, float(confidence), mask)))
            self.counts["proposals"] += 1

    def report(self) -> tuple[dict, dict]:
        return {}, {"teaching": self.teaching is not None, "teacher": self.teacher}


def main(conf: zenoh.Config, instance: str, teacher: str, params: dict, name: str, role: str = "teacher",
         start_on: bool = False) -> int:
    with BoxRuntime(conf, InstanceKeys(instance), role, name) as box:
        spaces = box.fetch_spaces()
        if spaces is None:
            return 0
        demonstrator = Demonstrator(box, spaces, make_teacher(teacher, spaces, **params), teacher)
        demonstrator.listen(role == "default")
        demonstrator.switch(start_on and role == "teacher")
        for batch in box.batches(0.1, demonstrator.report):
            demonstrator.handle(batch)
    return 0


def arg_parser() -> argparse.ArgumentParser:
    """The one reading of `dogged run demonstrator`'s arguments (a profile's are read with it too)."""
    parser = argparse.ArgumentParser(prog="dogged run demonstrator", description=__doc__.splitlines()[0])
    parser.add_argument("--instance", default="main")
    parser.add_argument("--name", default=None, help="this teacher's name (default: the plugin's)")
    parser.add_argument("--teacher", choices=sorted(TEACHERS), required=True)
    parser.add_argument("--param", action="append", help="teacher parameter name=value (repeatable)")
    parser.add_argument("--role", choices=("teacher", "default"), default="teacher")
    parser.add_argument("--on", action="store_true", help="start switched on")
    add_bus_args(parser)
    return parser


def cli(argv=None) -> int:
    parser = arg_parser()
    args = parser.parse_args(argv)
    return main(config_from_args(args), args.instance, args.teacher, parse_params(args.param),
                args.name or args.teacher, args.role, args.on)
