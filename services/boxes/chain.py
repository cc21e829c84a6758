"""Chains DL instances hierarchically: the upper instance's commands become the lower one's inputs.

The upper instance decides what to do (say, a movement from colour blobs); the lower one learns
how to do it on the robot (say, joint targets for that movement). This box is the upper's
platform side for commands and the lower's input source: each upper command (tick k) becomes
the lower input of tick k, optionally followed by the latest sample of an extra vector stream
(the robot's joint readings, for instance). It answers the lower instance's spaces: input the
upper's output space (plus the extra's), output the space of the box that consumes the lower
commands (the robot's or a further chain's).

With --clock extra the lower level keeps the extra stream's ticks instead: each extra sample
(the robot's gait clock at 60 Hz, say) becomes a lower input, after the latest upper command
(a movement decided at 15 Hz). An upper command older than --hold seconds (the upper level
stopped) gives way to the middle of the upper's output space (for a movement: stand still).
--ease S eases each new upper command in over S seconds (first order, the chain's own clock: real
time), as the hand-coded gait eases its own: a trot whose strides flip at 15 Hz threw the robot on
its back.
"""
from __future__ import annotations

import argparse
import collections
import time

import numpy as np
import zenoh

from bus_schema import Box, Command, InstanceKeys, Input, SpacesMessage, encode
from bus_schema.spaces import paced_like
from services.boxes.numbers import SECONDS, number
from services.bus.config import add_bus_args, config_from_args
from services.bus.inbox import decode_or_reject
from services.bus.runtime import BoxRuntime
from services.chaining import Easing, lower_spaces


def clip_counted(box: Box, values: np.ndarray, counts: collections.Counter, name: str) -> np.ndarray:
    """`values` clipped to `box`, counted under `name` when that changed them: the upper's arbitrator
    only sends commands in its output space, so anything outside was forged or broken, and the lower
    level would learn from an input no one can ask for."""
    clipped = box.clip(values)
    counts[name] += bool(np.any(clipped != values))
    return clipped


def main(conf: zenoh.Config, upper: str, lower: str, name: str, consumer_spaces: str, extra: str | None,
         clock: str = "upper", hold_s: float = 0.5, ease_s: float = 0.0) -> int:
    up, down = InstanceKeys(upper), InstanceKeys(lower)
    with BoxRuntime(conf, down, "chain", name) as box:  # its status and token in the lower instance
        rejects, counts = box.rejects, box.counts
        upper_spaces = box.fetch_spaces(up.spaces)
        consumer = box.fetch_spaces(consumer_spaces)
        extra_spaces = box.fetch_spaces(InstanceKeys(extra).spaces) if extra else None
        if upper_spaces is None or consumer is None or (extra and extra_spaces is None):
            return 0
        # the lower level ticks when its clock does: in lockstep when that clock's platform is
        spaces = paced_like(lower_spaces(upper_spaces, consumer, extra_spaces),
                            extra_spaces if clock == "extra" else upper_spaces)
        payload = encode(SpacesMessage(spaces.to_dict()))
        pub = box.sensor_publisher(down.input)
        box.subscribe(up.command, "command")
        box.queryable(down.spaces, "spaces")
        box.token(up.alive("platform", name))  # the upper instance's platform
        if extra:
            box.subscribe(InstanceKeys(extra).input, "extra")
        latest_extra = np.zeros(extra_spaces.input.dims) if extra_spaces else np.zeros(0)
        n_up = upper_spaces.output.dims
        rest = (np.asarray(upper_spaces.output.low) + np.asarray(upper_spaces.output.high)) / 2.0
        latest_up, latest_up_at = rest, -np.inf
        eased, eased_at = Easing(rest, ease_s), time.monotonic()
        box.log.info("chaining %s -> %s: %d inputs (%s)", upper, lower, spaces.input.dims,
                     ", ".join(spaces.input.names))
        for batch in box.batches(0.1, lambda: ({}, {"upper": upper, "lower": lower})):
            for tag, key, raw, _ in batch:
                if tag == "spaces":
                    raw.reply(down.spaces, payload)
                elif tag == "extra":
                    msg = decode_or_reject(Input, raw, key, rejects, {"x": len(latest_extra)})
                    if msg is not None:
                        latest_extra = clip_counted(extra_spaces.input, msg.x, counts, "clipped_extra")
                        if clock == "extra":
                            now = time.monotonic()
                            fresh = now - latest_up_at <= hold_s
                            counts["upper_stale"] += not fresh
                            command = eased.step(latest_up if fresh else rest, min(now - eased_at, 1.0))
                            eased_at = now
                            pub.put(encode(Input(msg.tick, msg.stamp, np.concatenate([command, msg.x]))))
                            counts["relayed"] += 1
                else:
                    msg = decode_or_reject(Command, raw, key, rejects, {"y": n_up})
                    if msg is None:
                        continue
                    y = clip_counted(upper_spaces.output, msg.y, counts, "clipped_upper")
                    if clock == "extra":
                        latest_up, latest_up_at = y, time.monotonic()
                        counts["upper_commands"] += 1
                    else:
                        pub.put(encode(Input(msg.tick, msg.stamp, np.concatenate([y, latest_extra]))))
                        counts["relayed"] += 1
    return 0


def arg_parser() -> argparse.ArgumentParser:
    """The one reading of `dogged run chain`'s arguments (a profile's are read with it too)."""
    parser = argparse.ArgumentParser(prog="dogged run chain", description=__doc__.splitlines()[0])
    parser.add_argument("--upper", required=True, help="the instance whose commands become inputs")
    parser.add_argument("--lower", required=True, help="the instance that takes them as its input")
    parser.add_argument("--consumer-spaces", required=True,
                        help="key of the spaces of whoever applies the lower commands, e.g. robot/aibo/spaces")
    parser.add_argument("--extra", default=None, help="an instance whose input stream is appended (e.g. joints)")
    parser.add_argument("--clock", choices=("upper", "extra"), default="upper",
                        help="whose ticks the lower level keeps: one per upper command, or one per extra sample")
    parser.add_argument("--hold", type=SECONDS, default=0.5, metavar="SECONDS",
                        help="with --clock extra: an upper command older than this gives way to rest")
    parser.add_argument("--ease", type=number(at_least=0.0, at_most=3600.0), default=0.0, metavar="SECONDS",
                        help="with --clock extra: ease each new upper command in over this time (0: at once)")
    parser.add_argument("--name", default="chain")
    parser.add_argument("--instance", help=argparse.SUPPRESS)
    add_bus_args(parser)
    return parser


def cli(argv=None) -> int:
    parser = arg_parser()
    a = parser.parse_args(argv)
    if a.clock == "extra" and not a.extra:
        parser.error("--clock extra needs --extra INSTANCE: the stream whose samples start the lower ticks")
    if not (np.isfinite(a.hold) and a.hold > 0):
        parser.error(f"--hold must be a positive number of seconds, got {a.hold}")
    if not (np.isfinite(a.ease) and a.ease >= 0):
        parser.error(f"--ease must be zero or a positive number of seconds, got {a.ease}")
    return main(config_from_args(a), a.upper, a.lower, a.name, a.consumer_spaces, a.extra, a.clock, a.hold,
                a.ease)
