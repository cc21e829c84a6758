"""The CLI's verbs: each one a short Zenoh conversation with a running supervisor or with teachers."""
from __future__ import annotations

import collections
import json
import logging
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
import zenoh

from bus_schema import (ArenaReset, Command, ControlReply, InstanceKeys, RobotKeys, RobotState, SchemaError,
                        TeachSwitch, decode, decoded, encode, supervisor_key, supervisor_token)
from services.bus.config import DEFAULT_ROUTER, zenoh_config
from services.bus.publishers import lossless_publisher, wait_matching
from services.bus.control import ask_supervisor, running_profile
from services.bus.queries import ask_owner
from services.own_identities import running_at
from services.supervisor.profile import ProfileError, ensure_security, load_profile
from services.waiting import poll


def up(profile_file: str, router: str | None, echo: bool, insecure: bool = False, join: str | None = None) -> int:
    from services.security import is_loopback
    from services.supervisor.supervisor import Supervisor
    logging.basicConfig(level="INFO", format="%(asctime)s %(levelname)s supervisor: %(message)s")
    try:
        profile = load_profile(profile_file, router, join=join)
        ensure_security(profile)
    except ProfileError as err:
        print(f"dogged up: {err}", file=sys.stderr)
        return 2
    beyond = [e for e in (profile.router, *profile.also_listen, profile.upstream) if e and not is_loopback(e)]
    if profile.security is None and beyond and not insecure:
        where = (f"the router would link to {profile.upstream} in the clear, and anyone who reaches it could drive "
                 f"the robot" if profile.upstream in beyond else f"the router would listen on {beyond[0]}, beyond "
                 f"this machine, and anyone who reaches it could drive the robot")
        print(f"dogged up: {where}: set zenoh.security to a `dogged certs` directory (mutual TLS and access "
              f"control), or say --insecure", file=sys.stderr)
        return 2
    print(profile.where_things_go(), flush=True)
    return Supervisor(profile, echo).run()


def wait_announced(profile_file: Path, router: str | None, supervisor, timeout: float = 60.0) -> None:
    """Once `dogged up profile_file [--router router]` (the process `supervisor`) has said where its router
    runs, if the profile is secured by this user's own identities: a session opened before would not know
    to speak TLS. RuntimeError if the supervisor exits first (it refused the profile, say), TimeoutError."""
    profile = load_profile(profile_file, router, check_security=False)
    if not profile.own_security:
        return

    def announced() -> bool:
        if supervisor.poll() is not None:
            raise RuntimeError(f"`dogged up {profile_file}` exited with {supervisor.returncode} before its router ran")
        return running_at(profile.router) is not None
    if not poll(announced, timeout):
        raise TimeoutError(f"`dogged up {profile_file}` did not announce its router within {timeout:.0f} s")


def certs(directory: str, profile_files: list[str] | None, identities: list[str], ca: str | None = None) -> int:
    """`dogged certs DIR [--ca CADIR] [--profile P ...] [--identity ROLE.NAME ...]`: the CA (made once, in
    CADIR, outside DIR) and a folder per identity in DIR; hand a person their folder (never CADIR)."""
    from services.certificates import default_ca_dir, make_certs
    from services.security import ROUTER_IDENTITY, role_of
    wanted = list(identities)
    for profile_file in reversed(profile_files or []):
        try:  # not yet the certificates it lacks: they are what this makes
            profile = load_profile(profile_file, check_security=False)
        except ProfileError as err:
            print(f"dogged certs: {err}", file=sys.stderr)
            return 2
        wanted = profile.identities() + wanted
    if not wanted:
        print("dogged certs: nothing to make: give --profile and/or --identity", file=sys.stderr)
        return 2
    wanted = list(dict.fromkeys(wanted))
    ca_dir = Path(ca) if ca else default_ca_dir(Path(directory))
    try:
        routers = [cn for cn in wanted if role_of(cn) == "router" and cn != ROUTER_IDENTITY]
        if routers:
            raise ValueError(f"{', '.join(routers)}: the router role is the router's own, {ROUTER_IDENTITY}, only "
                             "(access control would give any other nothing)")
        written = make_certs(Path(directory), wanted, ca_dir=ca_dir)
    except ValueError as err:
        print(f"dogged certs: {err}", file=sys.stderr)
        return 2
    made = {p.stem for p in written}
    kept = [cn for cn in wanted if cn not in made]
    print(f"{len(written)} certificates in {directory}, a folder each (CA: {ca_dir}, keep it private): "
          f"{', '.join(sorted(made)) or 'none'}" + (f"; kept: {', '.join(kept)}" if kept else ""))
    if written:
        print("a running profile knows only the identities it found at `dogged up`: restart it (dogged down, "
              "dogged up) to admit these")
    return 0


ROUTER_WAIT_S = 10.0


def _session(args):
    endpoint = args.connect or os.environ.get("DOGGED_CONNECT", DEFAULT_ROUTER)
    wait_s = args.wait or ROUTER_WAIT_S
    try:
        return zenoh.open(zenoh_config(connect=[endpoint], mode="client", give_up_after=wait_s))
    except zenoh.ZError as err:
        secured = "" if os.environ.get("DOGGED_SECURITY") else (
            "; a secured profile's router (tls/...) needs DOGGED_SECURITY and DOGGED_IDENTITY, and one another "
            "user runs (secured by default) lets in that user's own identities only")
        reason = str(err).split(" at /")[0]  # (the rest names zenoh's source file)
        raise SystemExit(f"dogged: cannot reach the router at {endpoint} within {wait_s:g} s "
                         f"({reason}){secured}") from None


def _profile(session, args) -> str | None:
    if args.profile:
        return args.profile
    name, problem = running_profile(session, several_hint=": use --profile")
    if name is None:
        print(problem, file=sys.stderr)
    return name


def _ask(args, verb: str, parameters: str = "", timeout: float = 5.0) -> ControlReply | None:
    with _session(args) as session:
        profile = _profile(session, args)
        if profile is None:
            return None
        reply, problem = ask_supervisor(session, profile, verb, parameters, timeout)
        if reply is None:
            print(problem, file=sys.stderr)
        return reply


def ps(args) -> int:
    reply = _ask(args, "ps")
    if reply is None:
        return 1
    if args.json:
        print(json.dumps(reply.data))
        return 0
    print(f"{'SERVICE':<17}{'BOX':<14}{'HOST':<12}{'PID':>8}  {'STATE':<9}{'RESTARTS':>9}{'UPTIME':>9}  RATES (/s)")
    rows = reply.data["services"]
    instances = list(dict.fromkeys(row.get("instance", "") for row in rows))
    heading = None
    for row in sorted(rows, key=lambda r: instances.index(r.get("instance", ""))):  # grouped, first seen first
        if len(instances) > 1 and row.get("instance", "") != heading:
            heading = row.get("instance", "")
            print(f"instance {heading}:" if heading else "the bus:")
        rates = " ".join(f"{k}={v:g}" for k, v in sorted(row["rates"].items()))
        ticks = " ".join(f"{k}={v:g}" for k, v in sorted(row.get("ticks", {}).items()))
        uptime = f"{row['uptime_s']:>8.0f}s" if row["state"] != "remote" else f"{'-':>9}"
        why = row.get("why") or (f"exit {row['exit']}" if row["state"] in ("failed", "backoff") else "")
        refused = " ".join(f"{k}={v}" for k, v in sorted(row.get("refused", {}).items()))
        refused = f"refused: {refused}" if refused else ""  # certificates not on the roster, which got nothing
        cpus = f"cpu {row['cpus']}" if row.get("cpus") else ""  # the profile's tick_cpus (services.placement)
        print(f"{row['name']:<16} {row['box']:<14}{row.get('host', '?')[:11]:<12}{row['pid']:>8}  {row['state']:<9}"
              f"{row['restarts']:>9}{uptime}  {' '.join(filter(None, (why, cpus, rates, ticks, refused)))}")
    return 0


def logs(args) -> int:
    reply = _ask(args, "logs", f"service={args.service};lines={args.lines}")
    if reply is None:
        return 1
    print(reply.text)
    return 0 if reply.ok else 1


# a swap's new learner learns the history first, as offline (services.boxes.learner), while the old one serves: an
# hour of mirroring's teaching (50,092 pairs) took the per-output GP about 4 min; the supervisor waits as long as it
# learns (services.supervisor.swap), and this as long as that may take
SWAP_WAIT_S = 1800.0


def swap(args) -> int:
    print(f"swapping: the new learner learns the history first while the old one serves (up to minutes; `dogged ps` "
          f"shows its backlog); waiting up to {SWAP_WAIT_S:g} s", file=sys.stderr)
    reply = _ask(args, "swap", f"service={args.service};spec={args.spec}", timeout=SWAP_WAIT_S)
    if reply is None:
        print("the swap may still be under way: `dogged ps` shows whether the new learner serves", file=sys.stderr)
        return 1
    print(reply.text)
    return 0 if reply.ok else 1


def down(args) -> int:
    with _session(args) as session:
        profile = _profile(session, args)
        if profile is None:
            return 1
        key = supervisor_key(profile, "down")
        payload, problem = ask_owner(session, key, 5.0)  # every queryable asked: the supervisor always hears it
        if payload is None and "different answers" not in problem:
            print(f"the supervisor of {profile} did not answer: {problem}", file=sys.stderr)
            return 1
        if problem:
            print(f"warning: {problem}", file=sys.stderr)
        # the supervisor's token goes when everything has stopped
        if poll(lambda: not any(r.ok is not None for r in session.liveliness().get(supervisor_token(profile),
                                                                                     timeout=1)), 30, 0.2):
            print(f"{profile}: stopped")
            return 0
    print(f"{profile}: still stopping after 30 s", file=sys.stderr)
    return 1


def teach(args) -> int:
    keys = InstanceKeys(args.instance)
    on = args.switch == "on"
    with _session(args) as session:
        pub = lossless_publisher(session, keys.teach)
        if not wait_matching(pub, 5.0):
            print(f"no teacher listens on {keys.teach}", file=sys.stderr)
            return 1
        pub.put(encode(TeachSwitch(args.teacher, on)))
        who = args.teacher or "every teacher"
        def confirmed():  # when the teaching tokens say so: who is teaching now
            teaching = {str(r.ok.key_expr).split("/")[-1]
                        for r in session.liveliness().get(keys.teaching("*"), timeout=1) if r.ok}
            done = (args.teacher in teaching) == on if args.teacher else bool(teaching) == on
            return done and (", ".join(sorted(teaching)) or "none teaching")
        teaching = poll(confirmed, 5, 0.1)
        if teaching:
            print(f"{who}: teaching {'on' if on else 'off'} ({teaching})")
            return 0
    print(f"{who} did not confirm teaching {'on' if on else 'off'}", file=sys.stderr)
    return 1


EARS = {"teacher": "RED    a teacher drives, the student learns",
        "student": "BLUE   the student drives",
        "unsure": "GREEN  the student is unsure: it asks to be taught (dogged teach on)"}


def watch(args) -> int:
    """The robot's ears in a terminal, for a person teaching from anywhere: a line each time the
    mode changes and holds for `--settle` seconds, and a warning when commands stop coming."""
    if not (args.settle >= 0 and args.seconds >= 0):
        print("dogged watch: --settle and --seconds must be 0 or more", file=sys.stderr)
        return 2
    keys = InstanceKeys(args.instance)
    arrived = collections.deque(maxlen=10_000)  # the callback only appends; this thread decodes and prints
    shown = candidate = None
    since = last_seen = time.monotonic()
    end = since + args.seconds if args.seconds > 0 else math.inf
    quiet_said = rejected = 0
    with _session(args) as session:
        session.declare_subscriber(keys.command, lambda sample: arrived.append(sample.payload.to_bytes()))
        print(f"watching {keys.command} (Ctrl-C to stop)", flush=True)
        try:
            while time.monotonic() < end:
                now = time.monotonic()
                while arrived:
                    try:
                        command = decode(Command, arrived.popleft(), keys.command)
                    except SchemaError as err:
                        rejected += 1
                        print(f"rejected a command: {err}", file=sys.stderr)
                        continue
                    last_seen, quiet_said = now, 0
                    if command.mode != candidate:
                        candidate, since = command.mode, now
                    if candidate != shown and now - since >= args.settle:
                        shown = candidate
                        bell = "\a" if args.bell and shown == "unsure" else ""
                        print(f"{time.strftime('%H:%M:%S')}  tick {command.tick:>8}  {EARS[shown]}  "
                              f"({command.source}, confidence {command.confidence:.2f}){bell}", flush=True)
                if now - last_seen > 2.0 and not quiet_said:
                    print(f"{time.strftime('%H:%M:%S')}  no commands for 2 s: is the loop running? (dogged ps)",
                          flush=True)
                    quiet_said = 1
                time.sleep(0.05)
        except KeyboardInterrupt:
            pass
    if rejected:
        print(f"{rejected} malformed commands rejected", file=sys.stderr)
    return 0


def parse_balls(items: list[str] | None) -> dict:
    """['pink=0.8,0.2', 'orange=off'] -> {'pink': [0.8, 0.2], 'orange': None}."""
    balls = {}
    for item in items or []:
        name, _, where = item.partition("=")
        try:
            balls[name] = None if where == "off" else [float(v) for v in where.split(",")]
        except ValueError:
            balls[name] = []
        if not name or (balls[name] is not None and (len(balls[name]) != 2 or not all(map(math.isfinite,
                                                                                          balls[name])))):
            raise ValueError(f"--ball {item!r}: expected NAME=X,Y (metres, the robot starts at 0,0 facing +x) "
                             "or NAME=off")
    return balls


def arena(args) -> int:
    """Rebuild the robot's arena from a seed and put balls down (or away); confirmed from the
    robot's own state stream (its simulated time starts again, the balls are where asked), so a request
    the robot rejected, or the bus refused, does not pass silently."""
    try:
        balls = parse_balls(args.ball)
        ArenaReset(args.seed, balls).check("--seed/--ball")
    except (ValueError, SchemaError) as err:
        print(f"dogged arena: {err}", file=sys.stderr)
        return 2
    keys = RobotKeys(args.robot)
    states = []
    with _session(args) as session:
        pub = lossless_publisher(session, keys.arena)
        if not wait_matching(pub, 5.0):
            print(f"no robot listens on {keys.arena}", file=sys.stderr)
            return 1
        held = session.declare_subscriber(keys.state, lambda sample: states.append(sample.payload.to_bytes()))
        if not poll(lambda: states, 5, 0.05):
            print(f"the robot sends no state on {keys.state}: nothing to confirm a reset by", file=sys.stderr)
            return 1
        before = len(states)
        pub.put(encode(ArenaReset(args.seed, balls)))

        def confirmed() -> bool:
            return reset_confirmed([decoded(RobotState, keys.state, raw) for raw in list(states)], before, balls)
        if poll(confirmed, 10, 0.1):
            said = ", ".join(f"{n} {'off' if xy is None else xy}" for n, xy in balls.items())
            print(f"arena {args.seed}: {said or 'balls as seeded'}")
            return 0
        del held
    print(f"the robot did not confirm the arena reset; see `dogged logs {args.robot}`", file=sys.stderr)
    return 1


def reset_confirmed(states: list[RobotState | None], asked_at: int, balls: dict) -> bool:
    """Whether the states from index `asked_at` on (those after the request) show the reset: the simulated
    time went back (a reset starts it from 0 again), and then the balls where asked."""
    times = [(i, s.sim_time) for i, s in enumerate(states) if s is not None]
    for (_, earlier), (i, later) in zip(times, times[1:]):
        if i >= asked_at and later < earlier:
            return any(s is not None and _balls_are_where_asked(s.balls, balls) for s in states[i:])
    return False


def _balls_are_where_asked(now: dict, asked: dict) -> bool:
    for name, xy in asked.items():
        if name not in now:
            return False
        distance = float(np.hypot(*(np.asarray(now[name][:2]) - (xy or [0.0, 0.0]))))
        # hidden balls are parked 40+ m out
        if (xy is None and distance < 30.0) or (xy is not None and distance > 0.05):
            return False
    return True
