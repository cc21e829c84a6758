"""Chains DL instances hierarchically: the upper instance's commands become the lower one's inputs.

The upper instance decides what to do (say, a movement from colour blobs); the lower one learns
how to do it on the robot (say, joint targets for that movement). This box is the upper's
platform side for commands and the lower's input source: each upper command (tick k) becomes
the lower input of tick k, optionally followed by the latest sample of an extra vector stream
(the robot's joint readings, for instance). It answers the lower instance's spaces: input the
upper's output space (plus the extra's), output the space of the box that consumes the lower
commands (the robot's or a further chain's).
"""
from __future__ import annotations

import argparse
import collections

import numpy as np
import zenoh

from bus_schema import Box, Command, InstanceKeys, Input, Spaces, SpacesMessage, encode
from services.boxes.common import fetch_spaces
from services.bus.config import add_bus_args, config_from_args
from services.bus.inbox import Inbox, Rejects, decode_or_reject
from services.bus.lifecycle import StopFlag, setup_logging
from services.bus.publishers import StatusPublisher, sensor_publisher


class SpacesAt:
    """fetch_spaces asks `<key>`; a chain asks the upper instance's spaces and the consumer's."""

    def __init__(self, key: str):
        self.spaces = key


def lower_spaces(upper: Spaces, consumer: Spaces, extra: Spaces | None) -> Spaces:
    box = upper.output
    if extra is not None:
        box = Box(box.low + extra.input.low, box.high + extra.input.high, box.names + extra.input.names,
                  box.units + extra.input.units)
    return Spaces(box, consumer.output, {"chained_from": "upper instance's output"})


def main(conf: zenoh.Config, upper: str, lower: str, name: str, consumer_spaces: str, extra: str | None) -> int:
    log = setup_logging("chain", name)
    stop, up, down, inbox = StopFlag(), InstanceKeys(upper), InstanceKeys(lower), Inbox()
    rejects, counts = Rejects(log), collections.Counter()
    with zenoh.open(conf) as session:
        upper_spaces = fetch_spaces(session, up, stop, log)
        consumer = fetch_spaces(session, SpacesAt(consumer_spaces), stop, log)
        extra_spaces = fetch_spaces(session, InstanceKeys(extra), stop, log) if extra else None
        if upper_spaces is None or consumer is None or (extra and extra_spaces is None):
            return 0
        spaces = lower_spaces(upper_spaces, consumer, extra_spaces)
        payload = encode(SpacesMessage(spaces.to_dict()))
        pub = sensor_publisher(session, down.input)
        held = [session.declare_subscriber(up.command, inbox.callback("command")),
                session.declare_queryable(down.spaces, inbox.query_callback("spaces")),
                session.liveliness().declare_token(up.alive("platform", name)),
                session.liveliness().declare_token(down.alive("chain", name))]
        if extra:
            held.append(session.declare_subscriber(InstanceKeys(extra).input, inbox.callback("extra")))
        status = StatusPublisher(session, down.status("chain", name), "chain", name)
        latest_extra = np.zeros(extra_spaces.input.dims) if extra_spaces else np.zeros(0)
        n_up = upper_spaces.output.dims
        log.info("chaining %s -> %s: %d inputs (%s)", upper, lower, spaces.input.dims, ", ".join(spaces.input.names))
        while not stop:
            for tag, key, raw, _ in inbox.drain(0.1):
                if tag == "spaces":
                    raw.reply(down.spaces, payload)
                elif tag == "extra":
                    msg = decode_or_reject(Input, raw, key, rejects, {"x": len(latest_extra)})
                    if msg is not None:
                        latest_extra = msg.x
                else:
                    msg = decode_or_reject(Command, raw, key, rejects, {"y": n_up})
                    if msg is not None:
                        pub.put(encode(Input(msg.tick, msg.stamp, np.concatenate([msg.y, latest_extra]))))
                        counts["relayed"] += 1
            status.maybe_publish(lambda: (dict(counts, rejected=rejects.total), {"upper": upper, "lower": lower}))
        del held
    return 0


def cli(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="dogged run chain", description=__doc__.splitlines()[0])
    parser.add_argument("--upper", required=True, help="the instance whose commands become inputs")
    parser.add_argument("--lower", required=True, help="the instance that takes them as its input")
    parser.add_argument("--consumer-spaces", required=True,
                        help="key of the spaces of whoever applies the lower commands, e.g. robot/aibo/spaces")
    parser.add_argument("--extra", default=None, help="an instance whose input stream is appended (e.g. joints)")
    parser.add_argument("--name", default="chain")
    parser.add_argument("--instance", help=argparse.SUPPRESS)
    add_bus_args(parser)
    a = parser.parse_args(argv)
    return main(config_from_args(a), a.upper, a.lower, a.name, a.consumer_spaces, a.extra)
