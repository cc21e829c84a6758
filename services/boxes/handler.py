"""The handler: a person moving the robot's joints by hand (the tail along a path, others at random).

It follows the robot's simulation clock, so the motion is the same in real time and in lockstep.
"""
from __future__ import annotations

import argparse

import zenoh

from bus_schema import Clock, Handle, InstanceKeys, RobotKeys, encode
from services.boxes.numbers import COUNT
from services.bus.config import add_bus_args, config_from_args
from services.bus.inbox import decode_or_reject
from services.bus.runtime import BoxRuntime
from services.platforms.aibo.handler import MIRRORING_DISTRACTORS, OTHER_16, Handler

DISTRACTORS = {"mirroring": MIRRORING_DISTRACTORS, "all": OTHER_16, "none": ()}


def main(conf: zenoh.Config, instance: str, name: str, robot: str, seed: int, tail: bool, distractors: str) -> int:
    robot_keys, hands = RobotKeys(robot), Handler(seed=seed, tail=tail, distractors=DISTRACTORS[distractors])
    with BoxRuntime(conf, InstanceKeys(instance), "handler", name) as box:
        pub = box.sensor_publisher(robot_keys.handle)
        box.subscribe(robot_keys.clock, "clock")
        box.log.info("handling %s: tail %s, distractors %s (seed %d)", robot, tail, distractors, seed)
        box.counts["handles"] = 0  # (in every status, from the first)
        for batch in box.batches(0.1, lambda: ({}, {"distractors": distractors})):
            newest = None
            for _, key, raw, _ in batch:
                newest = decode_or_reject(Clock, raw, key, box.rejects) or newest
            if newest is not None:
                mask, q = hands.at(newest.sim_time)
                pub.put(encode(Handle(mask.astype(float), q)))
                box.counts["handles"] += 1
    return 0


def arg_parser() -> argparse.ArgumentParser:
    """The one reading of `dogged run handler`'s arguments (a profile's are read with it too)."""
    parser = argparse.ArgumentParser(prog="dogged run handler", description=__doc__.splitlines()[0])
    parser.add_argument("--instance", default="main")
    parser.add_argument("--name", default="handler")
    parser.add_argument("--robot", default="aibo")
    parser.add_argument("--seed", type=COUNT, default=0)
    parser.add_argument("--no-tail", action="store_true", help="leave the tail alone")
    parser.add_argument("--distractors", choices=sorted(DISTRACTORS), default="mirroring",
                        help="which other joints move at random (mirroring: all but tail and head)")
    add_bus_args(parser)
    return parser


def cli(argv=None) -> int:
    parser = arg_parser()
    a = parser.parse_args(argv)
    return main(config_from_args(a), a.instance, a.name, a.robot, a.seed, not a.no_tail, a.distractors)
