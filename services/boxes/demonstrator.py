"""The demonstrator box: runs a teacher plugin; a person switches it on and off at runtime.

While on, it answers the newest input with the teacher's output and confidence, and holds a
liveliness token dl/<i>/alive/teaching/<name> so the arbitrator waits for it; while off it is
silent. With role 'default' it is Figure 1's default controller: always answering.
"""
from __future__ import annotations

import argparse
import collections

import zenoh

from bus_schema import InstanceKeys, Input, Proposal, TeachSwitch, decode, encode
from services.boxes.common import fetch_spaces
from services.bus import (Inbox, Rejects, StatusPublisher, StopFlag, add_bus_args, config_from_args, decode_or_reject,
                          sensor_publisher, setup_logging)
from services.params import parse_params
from services.teachers import TEACHERS, make_teacher


def main(conf: zenoh.Config, instance: str, teacher: str, params: dict, name: str, role: str = "teacher",
         start_on: bool = False) -> int:
    log = setup_logging(role, name)
    stop, keys, inbox = StopFlag(), InstanceKeys(instance), Inbox()
    rejects, counts = Rejects(log), collections.Counter()
    with zenoh.open(conf) as session:
        spaces = fetch_spaces(session, keys, stop, log)
        if spaces is None:
            return 0
        plugin = make_teacher(teacher, spaces, **params)
        dims = {"x": spaces.input.dims}
        pub = sensor_publisher(session, keys.proposal(role, name))
        held = []  # declarations live as long as these references (a dropped token is undeclared)
        held.append(session.declare_subscriber(keys.teach, inbox.callback("teach")))
        status = StatusPublisher(session, keys.status(role, name), role, name)
        held.append(session.liveliness().declare_token(keys.alive(role, name)))
        teaching = listening = None

        def listen(on: bool):
            # a silent teacher does not even hear the inputs: no wake-up per tick for nothing
            nonlocal listening
            if on and listening is None:
                listening = session.declare_subscriber(keys.input, inbox.callback("input"))
            elif not on and listening is not None:
                listening.undeclare()
                listening = None

        def switch(on: bool):
            nonlocal teaching
            if on and teaching is None:
                # the token first: the arbitrator takes a teacher's proposals only while it holds one
                teaching = session.liveliness().declare_token(keys.teaching(name))
                listen(True)
                log.info("teaching ON")
            elif not on and teaching is not None:
                teaching.undeclare()
                teaching = None
                listen(False)
                log.info("teaching OFF")

        listen(role == "default")
        switch(start_on and role == "teacher")
        while not stop:
            newest = None
            for tag, key, raw, _ in inbox.drain(0.1):
                if tag == "teach":
                    msg = decode_or_reject(lambda: decode(TeachSwitch, raw, key), rejects, key)
                    if msg is not None and msg.teacher in ("", name) and role == "teacher":
                        switch(msg.on)
                        counts["switches"] += 1
                else:
                    msg = decode_or_reject(lambda: decode(Input, raw, key, dims), rejects, key)
                    if msg is not None:
                        counts["inputs"] += 1
                        newest = msg  # latest-only: a stale input is not worth answering
            if newest is not None and (teaching is not None or role == "default"):
                y, confidence = plugin(newest.x)
                mask = getattr(plugin, "mask", None) if y is not None else None
                pub.put(encode(Proposal(newest.tick, f"{role}/{name}", y, float(confidence), mask)))
                counts["proposals"] += 1
            status.maybe_publish(lambda: (dict(counts, rejected=rejects.total),
                                          {"teaching": teaching is not None, "teacher": teacher}))
    return 0


def cli(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="dogged run demonstrator", description=__doc__.splitlines()[0])
    parser.add_argument("--instance", default="main")
    parser.add_argument("--name", default=None, help="this teacher's name (default: the plugin's)")
    parser.add_argument("--teacher", choices=sorted(TEACHERS), required=True)
    parser.add_argument("--param", action="append", help="teacher parameter name=value (repeatable)")
    parser.add_argument("--role", choices=("teacher", "default"), default="teacher")
    parser.add_argument("--on", action="store_true", help="start switched on")
    add_bus_args(parser)
    args = parser.parse_args(argv)
    return main(config_from_args(args), args.instance, args.teacher, parse_params(args.param),
                args.name or args.teacher, args.role, args.on)
