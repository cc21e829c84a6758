"""Flags into a Zenoh session: the one place that builds a zenoh.Config (scouting off, explicit
endpoints on loopback unless told otherwise, TLS and access control when a security directory is given)."""
from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import zenoh

DEFAULT_ROUTER = "tcp/127.0.0.1:7447"
LOCAL_LISTEN = "tcp/127.0.0.1:0"


def add_bus_args(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("bus")
    g.add_argument("--connect", action="append", default=None,
                   help=f"router endpoint(s) (default $DOGGED_CONNECT or {DEFAULT_ROUTER})")
    g.add_argument("--listen", action="append", default=None, help="endpoint(s) to listen on")
    g.add_argument("--mode", choices=("auto", "peer", "client", "router"), default="auto",
                   help="peer (direct links to the other services on this machine), client (all via the router), "
                        "router; auto (default): peer when the router is on loopback, else client")
    g.add_argument("--zenoh-config", default=None, help="a Zenoh JSON5 config file applied first")
    add_certificate_args(g)


def add_certificate_args(parser) -> None:
    # (dests of their own: `dogged certs` has an --identity of its own; no default of their own: the
    # parser's, which is "absent" where they follow a verb, see services/cli.py)
    parser.add_argument("--security", dest="cert_dir", metavar="DIR",
                        help="this identity's folder of a `dogged certs` directory (ca.pem, its key and "
                             "certificate), or that directory (default $DOGGED_SECURITY): mutual TLS to a secured "
                             "router")
    parser.add_argument("--identity", dest="cert_identity", metavar="ROLE.NAME",
                        help="which certificate of it to show, e.g. teacher.alice (default $DOGGED_IDENTITY)")


def use_certificate(args: argparse.Namespace) -> None:
    """--security/--identity stand for $DOGGED_SECURITY/$DOGGED_IDENTITY (zenoh_config reads those)."""
    if getattr(args, "cert_dir", None):
        os.environ["DOGGED_SECURITY"] = args.cert_dir
    if getattr(args, "cert_identity", None):
        os.environ["DOGGED_IDENTITY"] = args.cert_identity


def resolved_mode(mode: str, connect: list[str] | None) -> str:
    """"auto" is peer beside a router on loopback and client towards another machine's: peers listen on
    loopback, so peers on two machines could never link, and the router leaves peers to link themselves."""
    if mode != "auto":
        return mode
    from services.security import is_loopback
    endpoints = connect or [os.environ.get("DOGGED_CONNECT", DEFAULT_ROUTER)]
    return "peer" if all(is_loopback(e) for e in endpoints) else "client"


def zenoh_config(connect=None, listen=None, mode="auto", config_file=None,
                 give_up_after: float | None = None, security: Path | None = None,
                 identity: str | None = None, tell_refusals: bool = False) -> zenoh.Config:
    """Multicast scouting off; explicit endpoints on 127.0.0.1 unless told otherwise. With `security`
    (a `dogged certs` directory, or one identity's folder of it; default $DOGGED_SECURITY) and `identity`
    (this process's certificate; default $DOGGED_IDENTITY), mutual TLS, and the router and every peer
    enforcing who may say what for the roster ($DOGGED_ROSTER, else the directory's identities;
    services/security.py): peers link directly, so each checks what reaches it. A service (or a router
    linked to another machine's) keeps trying what it connects to; with `give_up_after` (seconds)
    opening fails instead. `tell_refusals`: a service's (or router's) Zenoh writes what access control refused
    on its stdout, its log, which its supervisor counts; an observer's or a verb's would only fill a terminal."""
    secured = security or os.environ.get("DOGGED_SECURITY")
    identity = identity or os.environ.get("DOGGED_IDENTITY")
    mode = resolved_mode(mode, connect)
    conf = zenoh.Config.from_file(config_file) if config_file else zenoh.Config()
    members = None
    if not secured and mode != "router":  # this user's own profile, secured by default: its identities
        found = own_profile(connect)
        if found:
            connect, secured, identity, members = found
    if secured:
        from services.refusals import log_refusals
        from services.security import roster, secure
        if not identity:
            raise ValueError("DOGGED_SECURITY is set but DOGGED_IDENTITY (this process's certificate) is not")
        # a peer links straight to other peers, so it enforces the access control itself, as the router does
        enforce = mode in ("router", "peer")
        secure(conf, Path(secured), identity, (members or roster(Path(secured))) if enforce else None)
        if enforce and tell_refusals:  # what it refuses, its supervisor counts from its log
            log_refusals()
        if mode == "peer":  # other peers link to it over TLS too
            listen = [endpoint.replace("tcp/", "tls/", 1) for endpoint in (listen or [LOCAL_LISTEN])]
    conf.insert_json5("mode", json.dumps(mode))
    conf.insert_json5("scouting/multicast/enabled", "false")
    # no shared memory: Zenoh maps each sender's segments (16 MiB of pool, 2 fds) to send a payload over 3 KiB
    # between processes of a machine, and keeps a dead sender's mapped for good (and its file in /dev/shm): a
    # camera's reader grew 19.4 MB and 2 fds at each restart of the camera (benchmarks/soak.py; the payloads
    # it would spare a copy of are frames of 20-300 kB, a few a tick)
    conf.insert_json5("transport/shared_memory/enabled", "false")
    # a latest-only message waits up to 20 ms for room before it is dropped (default 1 ms): on a
    # busy 2-core machine a sender thread can be descheduled that long without any real congestion
    conf.insert_json5("transport/link/tx/queue/congestion_control/drop/wait_before_drop", "20000")
    if mode == "router":  # it connects only to another machine's router, if told to
        conf.insert_json5("listen/endpoints", json.dumps(listen or [DEFAULT_ROUTER]))
    else:
        connect = connect or [os.environ.get("DOGGED_CONNECT", DEFAULT_ROUTER)]
        if mode == "peer":
            conf.insert_json5("listen/endpoints", json.dumps(listen or [LOCAL_LISTEN]))
    if connect:
        conf.insert_json5("connect/endpoints", json.dumps(connect))
        conf.insert_json5("connect/retry", json.dumps(CONNECT_RETRY))
        if give_up_after is None:  # a service: keep trying the router while it starts, and after a partition
            conf.insert_json5("connect/timeout_ms", "-1")
            conf.insert_json5("connect/exit_on_failure", "false")
        else:  # a person's command: say so rather than wait for ever
            conf.insert_json5("connect/timeout_ms", str(int(give_up_after * 1000)))
            conf.insert_json5("connect/exit_on_failure", "true")
    return conf


# a lost router is tried again every 0.1 s at first, 0.5 s at most (Zenoh's default: 1 s, doubling to 4 s): a router
# killed and back in 1.8 s had its sessions back 1.0-1.25 s after it (/tmp probe, 4 kills), and a fresh clone's CI
# failed the fault suite's 2 s recovery after the router's kill; this way 0.01 s after it
CONNECT_RETRY = {"period_init_ms": 100, "period_max_ms": 500, "period_increase_factor": 1.5}


def own_profile(connect: list[str] | None) -> tuple[list[str], Path, str, list[str]] | None:
    """(endpoints, identity folder, identity, roster) when the one router connected to is on loopback and
    runs a profile of this user's, secured (services/own_identities.py); else None."""
    from services.own_identities import identity_for_connecting
    from services.security import is_loopback
    endpoints = connect or [os.environ.get("DOGGED_CONNECT", DEFAULT_ROUTER)]
    if len(endpoints) != 1 or not is_loopback(endpoints[0]):
        return None
    found = identity_for_connecting(endpoints[0])
    return None if found is None else ([found[0]], found[1], found[2], found[3])


def config_from_args(args: argparse.Namespace) -> zenoh.Config:
    use_certificate(args)
    return zenoh_config(args.connect, args.listen, args.mode, args.zenoh_config, tell_refusals=True)
