"""The boxes: each services.boxes.<box> is a process with cli(argv) (`dogged run <box>`),
its arguments read by arg_parser().

BOX_ROLES is the one list of them: the role each one's certificate carries (services/security.py).
"""
import argparse
import importlib

BOX_ROLES = {"router": "router", "platform": "platform", "aibo": "platform", "demonstrator": "teacher",
             "learner": "learner", "arbitrator": "arbitrator", "perception": "perception", "handler": "handler",
             "chain": "chain", "recorder": "recorder", "ui": "operator"}


def parse_box_args(box: str, args) -> argparse.Namespace:
    """A box's arguments read by that box's own parser, as the process will read them (`--role=default`,
    `--state-dir /x`, an abbreviated flag alike); a ValueError saying what is wrong, never an exit."""
    parser = importlib.import_module(f"services.boxes.{box}").arg_parser()

    def refuse(message: str) -> None:
        raise ValueError(message)
    parser.error = refuse
    parser.exit = lambda status=0, message=None: refuse(message or "asks for help: not an argument a service runs with")
    return parser.parse_args(list(args))
