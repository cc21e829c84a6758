"""The demonstrator box: runs a teacher plugin; a person switches it on and off at runtime.

While on, it answers the newest input with the teacher's output and confidence, and holds a
liveliness token dl/<i>/alive/teaching/<name> so the arbitrator waits for it; while off it is
silent. With role 'default' it is Figure 1's default controller: always answering.
"""
from __future__ import annotations

import argparse
import collections

import zenoh

from bus_schema import InstanceKeys, Input, Proposal, TeachSwitch, encode
from services.boxes.common import fetch_spaces
from services.bus.config import add_bus_args, config_from_args
from services.bus.inbox import Inbox, Rejects, decode_or_reject
from services.bus.lifecycle import StopFlag, setup_logging
from services.bus.publishers import StatusPublisher, sensor_publisher
from services.params import parse_params
from services.teachers import TEACHERS, make_teacher


class Demonstrator:
    """The box's state: a teacher plugin, switched by the teach key, answering the newest input. Every
    declaration goes through `session`, so a fake one drives it in unit tests."""

    def __init__(self, session, keys: InstanceKeys, spaces, plugin, name: str, role: str, log):
        self.session, self.keys, self.plugin, self.name, self.role, self.log = session, keys, plugin, name, role, log
        self.inbox, self.rejects, self.counts = Inbox(), Rejects(log), collections.Counter()
        self.dims = {"x": spaces.input.dims}
        self.pub = sensor_publisher(session, keys.proposal(role, name))
        self.switches = session.declare_subscriber(keys.teach, self.inbox.callback("teach"))
        self.teaching = self.listening = None

    def listen(self, on: bool) -> None:
        """A silent teacher does not even hear the inputs: no wake-up per tick for nothing."""
        if on and self.listening is None:
            self.listening = self.session.declare_subscriber(self.keys.input, self.inbox.callback("input"))
        elif not on and self.listening is not None:
            self.listening.undeclare()
            self.listening = None

    def switch(self, on: bool) -> None:
        if on and self.teaching is None:
            # the token first: the arbitrator takes a teacher's proposals only while it holds one
            self.teaching = self.session.liveliness().declare_token(self.keys.teaching(self.name))
            self.listen(True)
            self.log.info("teaching ON")
        elif not on and self.teaching is not None:
            self.teaching.undeclare()
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

    def status(self) -> tuple[dict, dict]:
        return dict(self.counts, rejected=self.rejects.total), {"teaching": self.teaching is not None}


def main(conf: zenoh.Config, instance: str, teacher: str, params: dict, name: str, role: str = "teacher",
         start_on: bool = False) -> int:
    log = setup_logging(role, name)
    stop, keys = StopFlag(), InstanceKeys(instance)
    with zenoh.open(conf) as session:
        spaces = fetch_spaces(session, keys, stop, log)
        if spaces is None:
            return 0
        box = Demonstrator(session, keys, spaces, make_teacher(teacher, spaces, **params), name, role, log)
        alive = session.liveliness().declare_token(keys.alive(role, name))  # undeclared once unreferenced
        status = StatusPublisher(session, keys.status(role, name), role, name, inbox=box.inbox)
        box.listen(role == "default")
        box.switch(start_on and role == "teacher")

        def report():
            counters, state = box.status()
            return counters, dict(state, teacher=teacher)
        while not stop:
            box.handle(box.inbox.drain(0.1))
            status.maybe_publish(report)
        alive.undeclare()
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
