"""The ui box (`dogged ui`): a page in a browser where a person watches, teaches, corrects and
teleoperates the robot (services/ui). On loopback of an unsecured bus it needs no login; on a secured
bus (every profile unless it says security = "off") or any other address the page's socket needs the
token printed at start, and off loopback the page is served over HTTPS (a certificate
given with --tls-cert / --tls-key, else one made for the run, whose fingerprint is printed)."""
from __future__ import annotations

import argparse
import asyncio
import os
import secrets
import socket
import ssl
import sys
import threading
from pathlib import Path

import zenoh

from bus_schema import InstanceKeys, check_name
from services.bus.config import add_bus_args, config_from_args, own_profile
from services.bus.runtime import BoxRuntime
from services.own_identities import PAGE_TOKEN_ENV, forget_page, note_page
from services.security import is_loopback
from services.ui.bridge import FRAME_HEADER, Bridge
from services.ui.server import UiServer
from services.ui.tls import TlsError, server_tls
from services.ui.teleop import TELEOP_REFRESH_S


def page_token() -> str:
    """The token the page's socket asks: its profile's (the same across this ui's restarts), else a new one."""
    return os.environ.get(PAGE_TOKEN_ENV) or secrets.token_urlsafe(18)


def main(conf: zenoh.Config, instance: str, robot: str, person: str, host: str, port: int, name: str = "ui",
         tls: ssl.SSLContext | None = None, fingerprint: str = "", secured: bool = False) -> int:
    """`secured`: the bus lets in identities only, so the page does too: on loopback as well, its socket
    needs the token, which this user finds in their own folder (services/own_identities.py)."""
    box, done = BoxRuntime(conf, InstanceKeys(instance), "ui", name), threading.Event()
    log = box.log
    token = None if is_loopback(f"tcp/{host}:{port}") and not secured else page_token()
    if token and tls is None:
        log.warning("--plain-http off loopback: the token and all the page sends cross the network in clear")
    with box:
        spaces = box.fetch_spaces()
        if spaces is None:
            return 0
        out = spaces.output
        hello = {"version": 1, "instance": instance, "robot": robot, "person": person,
                 "outputs": {"names": list(out.names), "units": list(out.units), "low": list(out.low),
                             "high": list(out.high), "choice": spaces.extra.get("choice") == "largest"},
                 "inputs": {"names": list(spaces.input.names)}, "frame_header_bytes": FRAME_HEADER.size,
                 "teleop_refresh_ms": round(TELEOP_REFRESH_S * 1000)}
        server = UiServer(None, hello, host, port, token, log, tls)
        bridge = Bridge(box, robot, person, spaces, server.emit)
        server.bridge, bridge.server_counts = bridge, server.counts
        bridge.declare()  # here, not on the bus thread (Bridge.declare says why)
        box.announce()
        bus = threading.Thread(target=bridge.run, name="bus", daemon=True)
        bus.start()

        def listening(port_now: int) -> None:
            shown = {"127.0.0.1": "localhost", "0.0.0.0": socket.gethostname(), "::": socket.gethostname()}
            address = f"{'https' if tls else 'http'}://{shown.get(host, host)}:{port_now}/"
            bridge.url = address
            where = f"{address}?token={token}" if token else address
            certificate = f"; certificate SHA-256 {fingerprint}" if tls else ""
            log.info("the page: %s (instance %s, robot %s; teleoperation as teacher %s%s)", where, instance, robot,
                     person, certificate)
            if token:  # shown to this user only: the console of `dogged up` (logs are 0600) and their folder
                kept = note_page(port_now, where)
                print(f"dogged ui: open {where}{certificate}" + (f" (kept in {kept})" if kept else ""),
                      file=sys.stderr, flush=True)

        async def serve():
            watcher = asyncio.create_task(_watch(box.stop, done))
            try:
                await server.serve(done, listening)
            finally:
                done.set()
                box.stop.set()  # the bus thread ends while the loop still runs (it emits into it)
                watcher.cancel()
        try:
            asyncio.run(serve())
        except OSError as err:
            log.error("cannot serve the page on %s:%d: %s", host, port, err)
            return 2
        finally:
            done.set()
            box.stop.set()  # the bus thread's loop ends
            bus.join(2.0)
            forget_page(bridge.url)
    return 0


async def _watch(stop, done: threading.Event) -> None:
    while not stop and not done.is_set():
        await asyncio.sleep(0.1)
    done.set()


def arg_parser() -> argparse.ArgumentParser:
    """The one reading of `dogged run ui`'s arguments (a profile's are read with it too)."""
    parser = argparse.ArgumentParser(prog="dogged ui", description=__doc__.splitlines()[0])
    parser.add_argument("--instance", default="main", help="the DL instance the page shows and teaches")
    parser.add_argument("--robot", default="aibo", help="whose camera, state and arena the page shows")
    parser.add_argument("--person", default="person",
                        help="the teacher name the person's teleoperation proposes as (teacher/<person>)")
    parser.add_argument("--http", default="127.0.0.1:8080", metavar="HOST:PORT",
                        help="where the page is served (loopback: no login; elsewhere a token is printed); a taken "
                             "port gives way to the next free one of ten")
    parser.add_argument("--tls-cert", type=Path, metavar="PEM", help="the page's HTTPS certificate (with --tls-key); "
                        "off loopback without one, a certificate is made for the run and its fingerprint printed")
    parser.add_argument("--tls-key", type=Path, metavar="PEM", help="the certificate's private key")
    parser.add_argument("--plain-http", action="store_true",
                        help="off loopback, serve plain HTTP: the token and the page's traffic cross the network "
                             "in clear (a trusted network only)")
    parser.add_argument("--name", default="ui")
    add_bus_args(parser)
    return parser


def cli(argv=None) -> int:
    parser = arg_parser()
    a = parser.parse_args(argv)
    host, _, port = a.http.rpartition(":")
    if not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        parser.error(f"--http must be HOST:PORT, e.g. 127.0.0.1:8080, got {a.http!r}")
    for field, value in (("--person", a.person), ("--name", a.name), ("--instance", a.instance),
                         ("--robot", a.robot)):
        try:
            check_name(field, value)
        except ValueError as err:
            parser.error(str(err))
    host = host.strip("[]")
    tls, fingerprint = None, ""
    if a.plain_http and (a.tls_cert or a.tls_key):
        parser.error("--plain-http and --tls-cert/--tls-key contradict each other: give one or the other")
    if a.tls_cert or a.tls_key or not (a.plain_http or is_loopback(f"tcp/{host}:{port}")):
        try:
            tls, fingerprint = server_tls(host, a.tls_cert, a.tls_key)
        except TlsError as err:
            parser.error(str(err))
    secured = bool(os.environ.get("DOGGED_SECURITY")) or own_profile(a.connect) is not None
    return main(config_from_args(a), a.instance, a.robot, a.person, host, int(port), a.name, tls, fingerprint,
                secured)
