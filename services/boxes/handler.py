"""The handler: a person moving the robot's joints by hand (the tail along a path, others at random).

It follows the robot's simulation clock, so the motion is the same in real time and in lockstep.
"""
from __future__ import annotations

import argparse

import zenoh

from bus_schema import Clock, Handle, InstanceKeys, RobotKeys, encode
from services.bus.config import add_bus_args, config_from_args
from services.bus.inbox import Inbox, Rejects, decode_or_reject
from services.bus.lifecycle import StopFlag, setup_logging
from services.bus.publishers import StatusPublisher, sensor_publisher
from services.platforms.aibo.handler import MIRRORING_DISTRACTORS, OTHER_16, Handler

DISTRACTORS = {"mirroring": MIRRORING_DISTRACTORS, "all": OTHER_16, "none": ()}


def main(conf: zenoh.Config, instance: str, name: str, robot: str, seed: int, tail: bool, distractors: str) -> int:
    log = setup_logging("handler", name)
    stop, keys, robot_keys, inbox = StopFlag(), InstanceKeys(instance), RobotKeys(robot), Inbox()
    hands = Handler(seed=seed, tail=tail, distractors=DISTRACTORS[distractors])
    rejects, count = Rejects(log), 0
    with zenoh.open(conf) as session:
        pub = sensor_publisher(session, robot_keys.handle)
        held = [session.declare_subscriber(robot_keys.clock, inbox.callback("clock")),
                session.liveliness().declare_token(keys.alive("handler", name))]
        status = StatusPublisher(session, keys.status("handler", name), "handler", name, inbox=inbox)
        log.info("handling %s: tail %s, distractors %s (seed %d)", robot, tail, distractors, seed)
        while not stop:
            newest = None
            for _, key, raw, _ in inbox.drain(0.1):
                newest = decode_or_reject(Clock, raw, key, rejects) or newest
            if newest is not None:
                mask, q = hands.at(newest.sim_time)
                pub.put(encode(Handle(mask.astype(float), q)))
                count += 1
            status.maybe_publish(lambda count=count: ({"handles": count, "rejected": rejects.total},
                                                      {"distractors": distractors}))
        del held
    return 0


def arg_parser() -> argparse.ArgumentParser:
    """The one reading of `dogged run handler`'s arguments (a profile's are read with it too)."""
    parser = argparse.ArgumentParser(prog="dogged run handler", description=__doc__.splitlines()[0])
    parser.add_argument("--instance", default="main")
    parser.add_argument("--name", default="handler")
    parser.add_argument("--robot", default="aibo")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-tail", action="store_true", help="leave the tail alone")
    parser.add_argument("--distractors", choices=sorted(DISTRACTORS), default="mirroring",
                        help="which other joints move at random (mirroring: all but tail and head)")
    add_bus_args(parser)
    return parser


def cli(argv=None) -> int:
    parser = arg_parser()
    a = parser.parse_args(argv)
    return main(config_from_args(a), a.instance, a.name, a.robot, a.seed, not a.no_tail, a.distractors)
