"""Every key expression of the system. All keys of one DL instance live under dl/<instance>/."""
from __future__ import annotations

import re

_NAME = re.compile(r"^[a-z0-9][a-z0-9_-]{0,63}$")


def is_name(name) -> bool:
    """True for a name the bus accepts (lowercase letters, digits, '-' or '_', at most 64)."""
    return isinstance(name, str) and _NAME.match(name) is not None


def check_name(kind: str, name: str) -> str:
    if not is_name(name):
        raise ValueError(f"{kind} name {name!r} must be lowercase letters, digits, '-' or '_' (max 64)")
    return name


class _Keys:
    """Keys under one checked name; `every()`: the same keys with '*' for it, patterns over every
    one (access control)."""
    KIND = ""

    def __init__(self, name: str):
        self._build(check_name(self.KIND, name))

    @classmethod
    def every(cls):
        keys = cls.__new__(cls)
        keys._build("*")
        return keys

    def _build(self, name: str) -> None:
        raise NotImplementedError


class InstanceKeys(_Keys):
    """Key expressions of one DL instance (see bus_schema/README.md for the table)."""
    KIND = "instance"

    def _build(self, instance: str) -> None:
        self.instance = instance
        p = self.prefix = f"dl/{instance}"
        self.input = f"{p}/input"
        self.command = f"{p}/command"
        self.applied = f"{p}/applied"
        self.train = f"{p}/train"
        self.train_recent = f"{p}/train/recent"
        self.teach = f"{p}/teach"
        self.record = f"{p}/record"
        self.select_learner = f"{p}/arbitrator/select"
        self.spaces = f"{p}/spaces"
        self.reward = f"{p}/reward"
        self.episode = f"{p}/episode"
        self.proposals = f"{p}/proposal/**"
        self.alive_all = f"{p}/alive/**"

    def proposal(self, role: str, name: str) -> str:
        return f"{self.prefix}/proposal/{role}/{name}"

    def alive(self, role: str, name: str) -> str:
        return f"{self.prefix}/alive/{role}/{name}"

    def commanding(self, name: str) -> str:
        return f"{self.prefix}/alive/commanding/{name}"

    def teaching(self, name: str) -> str:
        return f"{self.prefix}/alive/teaching/{name}"

    def status(self, role: str, name: str) -> str:
        return f"{self.prefix}/status/{role}/{name}"

    def snapshot(self, learner: str) -> str:
        return f"{self.prefix}/learner/{learner}/snapshot"

    def history(self, learner: str) -> str:
        return f"{self.prefix}/learner/{learner}/history"

    def parse_alive(self, key: str) -> tuple[str, str] | None:
        """'dl/i/alive/learner/l1' -> ('learner', 'l1'); None for keys of other shapes."""
        parts = key.split("/")
        if len(parts) == 5 and parts[:3] == ["dl", self.instance, "alive"]:
            return parts[3], parts[4]
        return None


class RobotKeys(_Keys):
    """Key expressions of one robot's own streams, under robot/<name>/ (shared by the DL instances on it)."""
    KIND = "robot"

    def _build(self, robot: str) -> None:
        self.robot = robot
        p = self.prefix = f"robot/{robot}"
        self.camera = f"{p}/camera"
        self.clock = f"{p}/clock"
        self.handle = f"{p}/handle"
        self.arena = f"{p}/arena"
        self.spaces = f"{p}/spaces"
        self.state = f"{p}/state"


SUPERVISOR = "dogged/supervisor"
ROUTER = "dogged/router"
EVERY_ALIVE = "dl/*/alive/*/*"    # every member's liveliness token, in every instance (a supervisor's view)
EVERY_STATUS = "dl/*/status/*/*"  # every service's status, in every instance
EVERY_VERB = f"{SUPERVISOR}/*/*"  # every verb of every profile's supervisor (access control)
EVERY_ROUTER = f"{ROUTER}/*"  # every profile's router token (access control)


def supervisor_key(profile: str, verb: str) -> str:
    return f"{SUPERVISOR}/{check_name('profile', profile)}/{verb}"


def supervisor_token(profile: str) -> str:
    """The liveliness token of a profile's supervisor; '*': any profile's."""
    return f"{SUPERVISOR}/{profile if profile == '*' else check_name('profile', profile)}"


def router_token(profile: str) -> str:
    """The liveliness token a profile's router declares: one per profile, as the linked routers of several
    machines share one bus."""
    return f"{ROUTER}/{check_name('profile', profile)}"
