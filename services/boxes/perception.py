"""Perception: a robot's camera frames -> colour blobs -> the DL input (ball seeking's pre-processing).

Latest-only: if frames come faster than they are processed, the stale ones are skipped (counted).
It answers dl/<i>/spaces with its own input space and the robot's output space, or with
--output movement the movement the robot offers to an upper level (a walk level below learns the
legs: deploy/hierarchy.toml).
"""
from __future__ import annotations

import argparse
import time

import zenoh

from bus_schema import Box, Frame, InstanceKeys, Input, RobotKeys, Spaces, SpacesMessage, encode
from bus_schema.spaces import paced_like
from services.bus.config import add_bus_args, config_from_args
from services.bus.inbox import decode_or_reject
from services.bus.runtime import BoxRuntime
from services.perception.blobs import DEFAULT_COLOURS, BlobDetector
from services.perception.jpeg import decode_rgb
from services.perception.slots import BlobSlots


def parse_colours(items: list[str] | None) -> dict | None:
    """['pink=150,80,60,178,255,255', ...] -> {'pink': (((150, 80, 60), (178, 255, 255)),)}; several
    entries with one name add ranges (a red hue wrapping around 0)."""
    if not items:
        return None
    colours: dict = {}
    for item in items:
        name, _, numbers = item.partition("=")
        try:
            v = [int(n) for n in numbers.split(",")]
        except ValueError:
            v = []
        if not name or len(v) != 6 or not all(0 <= n <= 255 for n in v) or v[0] > 179 or v[3] > 179:
            raise SystemExit(f"--colour {item!r}: expected name=h_lo,s_lo,v_lo,h_hi,s_hi,v_hi (H 0-179, S,V 0-255)")
        colours[name] = colours.get(name, ()) + (((v[0], v[1], v[2]), (v[3], v[4], v[5])),)
    return colours


def output_box(robot_spaces: Spaces, output: str, robot: str) -> Box:
    """The instance's output: the robot's own commands, or the movement it offers to an upper level."""
    if output == "robot":
        return robot_spaces.output
    offered = robot_spaces.extra.get("movement")
    if offered is None:
        raise ValueError(f"robot {robot!r} offers no movement command (its spaces have no extra 'movement'); "
                         "run it with --command move or --command legs")
    try:
        return Box.from_dict(offered)
    except (KeyError, TypeError, ValueError) as err:
        raise ValueError(f"robot {robot!r} offers a malformed movement space: {err}") from None


def main(conf: zenoh.Config, instance: str, name: str, robot: str, colours: dict | None,
         layout: str = "colours", output: str = "robot") -> int:
    keys, robot_keys = InstanceKeys(instance), RobotKeys(robot)
    box = BoxRuntime(conf, keys, "perception", name)
    detector = BlobDetector(colours)
    # "slots": colour-blind slots, largest blob first, colour as one more input (services.perception.slots)
    slots = BlobSlots(detector) if layout == "slots" else None
    in_box = slots.box() if slots else detector.box()
    rejects, counts = box.rejects, box.counts
    with box:
        robot_spaces = box.fetch_spaces(robot_keys.spaces)
        if robot_spaces is None:
            return 0
        try:
            out_box = output_box(robot_spaces, output, robot)
        except ValueError as err:
            box.log.error("%s", err)
            return 2
        spaces = paced_like(Spaces(in_box, out_box, {"perception": f"colour blobs ({layout})", "robot": robot}),
                            robot_spaces)
        spaces_payload = encode(SpacesMessage(spaces.to_dict()))
        pub = box.sensor_publisher(keys.input)
        box.subscribe(robot_keys.camera, "frame")
        box.queryable(keys.spaces, "spaces")
        busy = 0.0
        box.log.info("blobs for %s -> %d inputs (%s)", ", ".join(detector.colours), spaces.input.dims,
                     ", ".join(spaces.input.names))

        def report():
            return {}, {"ms_per_frame": round(1e3 * busy / max(1, counts["frames"]), 3)}
        for batch in box.batches(0.1, report):
            newest = None
            for tag, key, raw, _ in batch:
                if tag == "spaces":
                    raw.reply(keys.spaces, spaces_payload)
                else:
                    frame = decode_or_reject(Frame, raw, key, rejects)
                    if frame is not None:
                        counts["skipped"] += newest is not None
                        newest = frame
            if newest is not None:
                started = time.perf_counter()
                try:
                    x = detector.detect(decode_rgb(newest.jpeg))
                    x = slots.encode(x) if slots else x
                except ValueError as err:  # a JPEG that does not decode
                    rejects(robot_keys.camera, err)
                    continue
                pub.put(encode(Input(newest.tick, newest.stamp, x)))
                busy += time.perf_counter() - started
                counts["frames"] += 1
    return 0


def arg_parser() -> argparse.ArgumentParser:
    """The one reading of `dogged run perception`'s arguments (a profile's are read with it too)."""
    parser = argparse.ArgumentParser(prog="dogged run perception", description=__doc__.splitlines()[0])
    parser.add_argument("--instance", default="main")
    parser.add_argument("--name", default="perception")
    parser.add_argument("--robot", default="aibo")
    parser.add_argument("--colour", action="append", metavar="NAME=H,S,V,H,S,V",
                        help=f"HSV range of a colour (repeatable; default {', '.join(DEFAULT_COLOURS)})")
    parser.add_argument("--layout", choices=("colours", "slots"), default="colours",
                        help="colours: 4 inputs per colour; slots: blobs largest first, colour an input")
    parser.add_argument("--output", choices=("robot", "movement"), default="robot",
                        help="the instance's output: the robot's commands, or the movement it offers (hierarchy)")
    add_bus_args(parser)
    return parser


def cli(argv=None) -> int:
    parser = arg_parser()
    a = parser.parse_args(argv)
    return main(config_from_args(a), a.instance, a.name, a.robot, parse_colours(a.colour), a.layout, a.output)
