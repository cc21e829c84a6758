"""The Zenoh router, as a Python process (no zenohd is needed): every service connects here."""
from __future__ import annotations

import argparse
import time

import zenoh

from bus_schema import ROUTER
from services.bus.config import DEFAULT_ROUTER, zenoh_config
from services.bus.lifecycle import setup_logging
from services.bus.runtime import BoxRuntime


CANNOT_LISTEN = "the router cannot listen on"  # what it says when it cannot start (its supervisor reads it)
ROUTING = "routing on"  # what it says once it listens


def main(listen: list[str], connect: list[str] | None = None, token: str = ROUTER) -> int:
    log = setup_logging("router", "router")  # first: securing its config may log
    # no instance: no status; its token (its supervisor's router_token()) says it is up
    conf = zenoh_config(listen=listen, connect=connect, mode="router", tell_refusals=True)
    box = BoxRuntime(conf, None, "router", "router", token=token, log=log)
    try:
        box.open()
    except zenoh.ZError as err:  # a port another program holds, a mistyped endpoint
        box.log.error("%s %s: %s", CANNOT_LISTEN, ", ".join(listen), str(err).split(" at /")[0])
        return 2
    with box:
        box.announce()
        box.log.info("%s %s%s", ROUTING, ", ".join(listen), f", linked to {', '.join(connect)}" if connect else "")
        while not box.stop:
            time.sleep(0.2)
    return 0


def arg_parser() -> argparse.ArgumentParser:
    """The one reading of `dogged run router`'s arguments (a profile's are read with it too)."""
    parser = argparse.ArgumentParser(prog="dogged run router", description=__doc__.splitlines()[0])
    parser.add_argument("--listen", action="append", default=None, help=f"endpoint(s), default {DEFAULT_ROUTER}")
    parser.add_argument("--connect", action="append", default=None,
                        help="another machine's router to link to (kept trying; one deployment over both)")
    parser.add_argument("--token", default=ROUTER,
                        help="the liveliness token that says this router is up (its supervisor's)")
    parser.add_argument("--instance", help=argparse.SUPPRESS)
    parser.add_argument("--name", help=argparse.SUPPRESS)
    return parser


def cli(argv=None) -> int:
    parser = arg_parser()
    args = parser.parse_args(argv)
    return main(args.listen or [DEFAULT_ROUTER], args.connect, args.token)
