"""A stranger's burst at a running profile, secured as deployed (benchmarks/soak.py runs it as a process of
its own, with none of this user's identities):

    python -m rigs.soak.stranger ENDPOINT FOLDER [--cases N] [--epoch E --seq S]

It tries three ways in, as a stranger on this machine could: plain TCP with no certificate; TLS with a
certificate of a CA of its own; TLS with a certificate of this user's CA made after the profile read its
roster (what a leaked CA key would give; FOLDER/inside holds it, made by the soak). Over whichever way
opens a session it puts N malformed and hostile payloads, on every key a service reads
(rigs/fuzz.py's cases). Prints one JSON object: per way, whether a session opened, and
how many payloads went out. The profile must refuse all of it: the first two at the door, the third by
its access control (the supervisor counts that refusal, `dogged ps`); no service may see one payload.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np
import zenoh

from bus_schema import InstanceKeys, RobotKeys
from services.bus.config import zenoh_config
from services.certificates import make_certs
from rigs.fuzz import cases

INSIDE = "teacher.stranger"  # this user's CA, not on the roster
FORGED = "teacher.eve"       # a CA of its own


def ways(endpoint: str, folder: Path) -> dict[str, tuple[str, Path | None, str | None]]:
    """Each way in: (endpoint, security folder, identity)."""
    plain = endpoint.replace("tls/", "tcp/", 1)
    return {"plain": (plain, None, None), "forged_ca": (endpoint, folder / "eve" / FORGED, FORGED),
            "off_roster": (endpoint, folder / "inside" / INSIDE, INSIDE)}


def burst(endpoint: str, folder: Path, n: int, epoch: str, seq: int, seed: int = 0) -> dict:
    if not (folder / "eve").is_dir():
        make_certs(folder / "eve", [FORGED])
    keys, robot, out = InstanceKeys("main"), RobotKeys("aibo"), {}
    todo = cases(np.random.default_rng(seed), keys, robot, n, epoch, seq)
    for way, (at, security, identity) in ways(endpoint, folder).items():
        try:
            conf = zenoh_config(connect=[at], mode="client", give_up_after=2.0, security=security, identity=identity)
            session = zenoh.open(conf)
        except (zenoh.ZError, ValueError, FileNotFoundError) as err:
            out[way] = {"session": False, "sent": 0, "why": str(err)[:200]}
            continue
        sent = 0
        try:
            for case in todo:
                session.put(case.key, case.payload)
                sent += 1
        finally:
            session.close()
        out[way] = {"session": True, "sent": sent}
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("endpoint", help="the profile's router (tls/127.0.0.1:PORT)")
    parser.add_argument("folder", help="the stranger's own folder (its CA; `inside`: this user's CA's stranger)")
    parser.add_argument("--cases", type=int, default=1000)
    parser.add_argument("--epoch", default="stranger")
    parser.add_argument("--seq", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    if os.environ.get("DOGGED_SECURITY"):
        parser.error("run as a stranger: without DOGGED_SECURITY (and with a DOGGED_HOME of its own)")
    print(json.dumps(burst(args.endpoint, Path(args.folder), args.cases, args.epoch, args.seq, args.seed)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
