"""`dogged`: run a box, bring a profile up or down, list, read logs, swap a learner, switch teachers,
watch the robot's mode, reset the robot's arena, replay a recorded run or play it into a live bus, export a
recorded run (a LeRobot dataset, its student as a file) or a running learner's student."""
from __future__ import annotations

import argparse
import importlib
import os
import sys

from services.boxes import BOX_ROLES
from services.own_identities import ROLE_ENV

BOXES = {name: f"services.boxes.{name}" for name in BOX_ROLES}


# verbs that parse their own arguments (`run` too): the module and function that do
OWN_PARSERS = {"ui": ("services.boxes.ui", "cli"), "demo": ("services.demo", "cli"),
               "replay": ("services.replay.cli", "replay_main"), "play": ("services.replay.cli", "play_main"),
               "export": ("services.export.cli", "export_main"), "snapshot": ("services.export.cli", "snapshot_main")}


def run_box(argv: list[str]) -> int:
    if not argv or argv[0] not in BOXES:
        print(f"usage: dogged run <box> [options]; boxes: {', '.join(BOXES)}", file=sys.stderr)
        return 2
    # on this user's own secured profile, a box run by hand shows this user's identity of its role
    os.environ.setdefault(ROLE_ENV, BOX_ROLES[argv[0]])
    return importlib.import_module(BOXES[argv[0]]).cli(argv[1:])


def run_own_parser(verb: str, argv: list[str]) -> int:
    if verb == "run":
        return run_box(argv)
    module, function = OWN_PARSERS[verb]
    return getattr(importlib.import_module(module), function)(argv)


def split_at_verb(argv: list[str]) -> tuple[list[str], str | None, list[str]]:
    """(the global flags before the verb, the verb, what follows it); no verb when something else comes
    first (--help, an unknown flag), which the verbs' parser then explains."""
    parser = argparse.ArgumentParser(add_help=False, parents=[global_flags()])
    parser.add_argument("verb", nargs="?")
    parser.add_argument("rest", nargs=argparse.REMAINDER)
    args, unknown = parser.parse_known_args(argv)
    if unknown or args.verb is None:
        return [], None, argv
    return argv[:len(argv) - len(args.rest) - 1], args.verb, args.rest


def main(argv: list[str] | None = None) -> int:
    from services.bus.config import use_certificate
    argv = sys.argv[1:] if argv is None else argv
    before, verb, after = split_at_verb(argv)
    if verb == "run" or verb in OWN_PARSERS:  # flags given before the verb mean what they mean after it
        return run_own_parser(verb, [*after, *before])
    args = verbs_parser().parse_args(argv)
    use_certificate(args)
    if args.verb == "up":
        from services.supervisor.commands import up
        return up(args.profile_file, args.router, not args.quiet, args.insecure, args.join)
    if args.verb == "certs":
        from services.supervisor.commands import certs
        return certs(args.directory, args.profile_file, args.identity, args.ca)
    from services.supervisor import commands
    return getattr(commands, args.verb)(args)


def global_flags(after_verb: bool = False) -> argparse.ArgumentParser:
    """The flags that say which bus and profile a verb talks to, and as whom. Given after the verb they
    default to nothing: argparse would let a verb's defaults overwrite what was given before it."""
    from services.boxes.numbers import SECONDS
    from services.bus.config import add_certificate_args
    parser = argparse.ArgumentParser(add_help=False, argument_default=argparse.SUPPRESS if after_verb else None)
    parser.add_argument("--connect", help="router endpoint (default $DOGGED_CONNECT or tcp/127.0.0.1:7447)")
    parser.add_argument("--profile", help="which running profile (default: the only one)")
    parser.add_argument("--wait", type=SECONDS, metavar="SECONDS",
                        help="how long to try reaching the router before saying it cannot (default 10)")
    add_certificate_args(parser)
    return parser


def verbs_parser() -> argparse.ArgumentParser:
    """`dogged <verb>`: the supervisor's verbs (`run`, `ui`, `demo`, `replay`, `play`, `export` and `snapshot`
    parse their own arguments)."""
    parser = argparse.ArgumentParser(prog="dogged", description=__doc__, parents=[global_flags()],
                                     epilog="--connect, --profile, --security and --identity go before the verb "
                                            "or after it (up and certs do not use them).")
    sub = parser.add_subparsers(dest="verb", required=True)
    flags_after_verb = [global_flags(after_verb=True)]

    def asks_supervisor(verb: str, help: str) -> argparse.ArgumentParser:
        return sub.add_parser(verb, parents=flags_after_verb, help=help)

    sub.add_parser("run", help="run one box: dogged run <box> --help")
    sub.add_parser("ui", help="a page in a browser to watch, teach and teleoperate the robot (dogged ui --help)")
    sub.add_parser("demo", help="the headline demo: ball seeking end to end (dogged demo --help)")
    sub.add_parser("replay", help="retrain learners on a recorded run and compare them (dogged replay --help)")
    sub.add_parser("play", help="publish a recorded run's inputs in place of the platform (dogged play --help)")
    sub.add_parser("export", help="a recorded run as a LeRobot dataset, its student as a file (dogged export --help)")
    sub.add_parser("snapshot", help="a running learner's student as a file: dogged snapshot learner FILE")
    up = sub.add_parser("up", help="start a router and every service of a profile; Ctrl-C stops all")
    up.add_argument("profile_file")
    up.add_argument("--router", default=None, help="override the profile's router endpoint")
    up.add_argument("--join", default=None, metavar="ENDPOINT",
                    help="start no router: join the one another machine runs (e.g. tls/192.168.1.10:7447)")
    up.add_argument("--quiet", action="store_true", help="do not echo service logs to the console")
    up.add_argument("--insecure", action="store_true", help="listen beyond loopback without TLS and access control")
    certs = sub.add_parser("certs", help="a CA and certificates: every identity a profile needs, and people's")
    certs.add_argument("directory", help="the services' directory: ca.pem and a folder per identity")
    certs.add_argument("--ca", default=None, metavar="CADIR",
                       help="the CA's directory, outside DIRECTORY (default: its sibling DIRECTORY-ca); made once")
    certs.add_argument("--profile", dest="profile_file", action="append", default=None,
                       help="make every identity this profile needs (repeatable: one CA for several machines)")
    certs.add_argument("--identity", action="append", default=[], metavar="ROLE.NAME",
                       help="one more, e.g. operator.bob or teacher.alice (repeatable)")
    asks_supervisor("down", help="stop a running profile")
    ps = asks_supervisor("ps", help="list services: pid, state, restarts, uptime, message rates")
    ps.add_argument("--json", action="store_true", help="one JSON object, for scripts")
    logs = asks_supervisor("logs", help="one service's log")
    logs.add_argument("service")
    logs.add_argument("-n", "--lines", type=int, default=50)
    swap = asks_supervisor("swap", help="hot-swap a learner: dogged swap learner <spec>")
    swap.add_argument("what", choices=["learner"])
    swap.add_argument("spec", help="learner name with optional params, e.g. sogp or lwpr:init_d=25")
    swap.add_argument("--service", default="", help="which learner service (default: the only one)")
    teach = asks_supervisor("teach", help="switch teachers on or off")
    teach.add_argument("switch", choices=["on", "off"])
    teach.add_argument("--teacher", default="", help="teacher name (default: every teacher)")
    teach.add_argument("--instance", default="main")
    watch = asks_supervisor("watch", help="the robot's ears in a terminal: a line each time the mode changes")
    watch.add_argument("--instance", default="main")
    watch.add_argument("--settle", type=float, default=0.2, help="seconds a mode must hold before it is shown")
    watch.add_argument("--seconds", type=float, default=0.0, help="stop after this long (default: until Ctrl-C)")
    watch.add_argument("--bell", action="store_true", help="ring the terminal bell when the robot asks to be taught")
    arena = asks_supervisor("arena",
                            help="rebuild the robot's arena and put balls down: dogged arena --ball pink=0.8,0.2")
    arena.add_argument("--seed", type=int, default=0, help="arena seed: clutter and where the robot starts (default 0)")
    arena.add_argument("--ball", action="append", metavar="NAME=X,Y|NAME=off",
                       help="put a ball at X,Y metres (the robot starts at 0,0 facing +x), "
                            "or take it away (repeatable)")
    arena.add_argument("--robot", default="aibo")
    return parser


if __name__ == "__main__":
    sys.exit(main())
