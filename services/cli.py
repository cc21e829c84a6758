"""`dogged`: run a box, bring a profile up or down, list, read logs, swap a learner, switch teachers,
watch the robot's mode, reset the robot's arena, replay a recorded run or play it into a live bus."""
from __future__ import annotations

import argparse
import importlib
import sys

from services.boxes import BOX_ROLES

BOXES = {name: f"services.boxes.{name}" for name in BOX_ROLES}


def run_box(argv: list[str]) -> int:
    if not argv or argv[0] not in BOXES:
        print(f"usage: dogged run <box> [options]; boxes: {', '.join(BOXES)}", file=sys.stderr)
        return 2
    return importlib.import_module(BOXES[argv[0]]).cli(argv[1:])


def main(argv: list[str] | None = None) -> int:
    from services.bus.config import use_certificate
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["run"]:
        return run_box(argv[1:])
    if argv[:1] == ["ui"]:
        return run_box(argv)
    if argv[:1] == ["demo"]:
        from services.demo import cli as demo
        return demo(argv[1:])
    if argv[:1] == ["replay"]:
        from services.recording.cli import replay_main
        return replay_main(argv[1:])
    if argv[:1] == ["play"]:
        from services.recording.cli import play_main
        return play_main(argv[1:])
    args = verbs_parser().parse_args(argv)
    use_certificate(args)
    if args.verb == "up":
        from services.supervisor.commands import up
        return up(args.profile_file, args.router, not args.quiet, args.insecure, args.join)
    if args.verb == "certs":
        from services.supervisor.commands import certs
        return certs(args.directory, args.profile_file, args.identity)
    from services.supervisor import commands
    return getattr(commands, args.verb)(args)


def verbs_parser() -> argparse.ArgumentParser:
    """`dogged <verb>`: the supervisor's verbs (`run`, `demo`, `replay` and `play` parse their own arguments)."""
    from services.bus.config import add_certificate_args
    parser = argparse.ArgumentParser(prog="dogged", description=__doc__)
    parser.add_argument("--connect", default=None,
                        help="router endpoint (default $DOGGED_CONNECT or tcp/127.0.0.1:7447)")
    parser.add_argument("--profile", default=None, help="which running profile (default: the only one)")
    add_certificate_args(parser)
    sub = parser.add_subparsers(dest="verb", required=True)
    sub.add_parser("run", help="run one box: dogged run <box> --help")
    sub.add_parser("ui", help="a page in a browser to watch, teach and teleoperate the robot (dogged ui --help)")
    sub.add_parser("demo", help="the headline demo: ball seeking end to end (dogged demo --help)")
    sub.add_parser("replay", help="retrain learners on a recorded run and compare them (dogged replay --help)")
    sub.add_parser("play", help="publish a recorded run's inputs in place of the platform (dogged play --help)")
    up = sub.add_parser("up", help="start a router and every service of a profile; Ctrl-C stops all")
    up.add_argument("profile_file")
    up.add_argument("--router", default=None, help="override the profile's router endpoint")
    up.add_argument("--join", default=None, metavar="ENDPOINT",
                    help="start no router: join the one another machine runs (e.g. tls/192.168.1.10:7447)")
    up.add_argument("--quiet", action="store_true", help="do not echo service logs to the console")
    up.add_argument("--insecure", action="store_true", help="listen beyond loopback without TLS and access control")
    certs = sub.add_parser("certs", help="a CA and certificates: every identity a profile needs, and people's")
    certs.add_argument("directory")
    certs.add_argument("--profile", dest="profile_file", action="append", default=None,
                       help="make every identity this profile needs (repeatable: one CA for several machines)")
    certs.add_argument("--identity", action="append", default=[], metavar="ROLE.NAME",
                       help="one more, e.g. operator.bob or teacher.alice (repeatable)")
    sub.add_parser("down", help="stop a running profile")
    ps = sub.add_parser("ps", help="list services: pid, state, restarts, uptime, message rates")
    ps.add_argument("--json", action="store_true", help="one JSON object, for scripts")
    logs = sub.add_parser("logs", help="one service's log")
    logs.add_argument("service")
    logs.add_argument("-n", "--lines", type=int, default=50)
    swap = sub.add_parser("swap", help="hot-swap a learner: dogged swap learner <spec>")
    swap.add_argument("what", choices=["learner"])
    swap.add_argument("spec", help="learner name with optional params, e.g. sogp or lwpr:init_d=25")
    swap.add_argument("--service", default="", help="which learner service (default: the only one)")
    teach = sub.add_parser("teach", help="switch teachers on or off")
    teach.add_argument("switch", choices=["on", "off"])
    teach.add_argument("--teacher", default="", help="teacher name (default: every teacher)")
    teach.add_argument("--instance", default="main")
    watch = sub.add_parser("watch", help="the robot's ears in a terminal: a line each time the mode changes")
    watch.add_argument("--instance", default="main")
    watch.add_argument("--settle", type=float, default=0.2, help="seconds a mode must hold before it is shown")
    watch.add_argument("--seconds", type=float, default=0.0, help="stop after this long (default: until Ctrl-C)")
    watch.add_argument("--bell", action="store_true", help="ring the terminal bell when the robot asks to be taught")
    arena = sub.add_parser("arena",
                           help="rebuild the robot's arena and put balls down: dogged arena --ball pink=0.8,0.2")
    arena.add_argument("--seed", type=int, default=0, help="arena seed: clutter and where the robot starts (default 0)")
    arena.add_argument("--ball", action="append", metavar="NAME=X,Y|NAME=off",
                       help="put a ball at X,Y metres (the robot starts at 0,0 facing +x), "
                            "or take it away (repeatable)")
    arena.add_argument("--robot", default="aibo")
    return parser

if __name__ == "__main__":
    sys.exit(main())
