"""The Zenoh router, as a Python process (no zenohd is needed): every service connects here."""
from __future__ import annotations

import argparse
import time

import zenoh

from services.bus import DEFAULT_ROUTER, StopFlag, setup_logging, zenoh_config


def main(listen: list[str]) -> int:
    log = setup_logging("router", "router")
    stop = StopFlag()
    with zenoh.open(zenoh_config(listen=listen, mode="router")) as session:
        held = []  # declarations live as long as these references (a dropped token is undeclared)
        held.append(session.liveliness().declare_token("dogged/router"))  # the supervisor's ROUTER_TOKEN
        log.info("routing on %s", ", ".join(listen))
        while not stop:
            time.sleep(0.2)
    return 0


def cli(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="dogged run router", description=__doc__.splitlines()[0])
    parser.add_argument("--listen", action="append", default=None, help=f"endpoint(s), default {DEFAULT_ROUTER}")
    parser.add_argument("--instance", help=argparse.SUPPRESS)
    parser.add_argument("--name", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    return main(args.listen or [DEFAULT_ROUTER])
