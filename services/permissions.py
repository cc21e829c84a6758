"""What each role may say on the bus (issue 30): the allow-list services/security.py gives Zenoh.

Each role's part is every key its services put on, hold a liveliness token on, answer (declare a
queryable and reply on) or ask (query), as services/boxes, services/ui and services/supervisor write
them, with '*' for an instance, a robot or a name. Zenoh allows a message only when an allowed key
expression includes the message's key, so a wildcard (`dl/**`, `dl/main/alive/**`) that reaches past a
role's part is refused whole. Subscribing is not in the table: every identity on the roster may listen.
Nobody deletes.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

from bus_schema.keys import EVERY_ROUTER, EVERY_VERB, ROUTER, InstanceKeys, RobotKeys, supervisor_token


@dataclass(frozen=True)
class Part:
    """A role's key expressions, by what it does with them."""
    put: tuple[str, ...] = ()
    token: tuple[str, ...] = ()
    answer: tuple[str, ...] = ()
    ask: tuple[str, ...] = ()

    def kinds(self) -> list[tuple[str, tuple[str, ...]]]:
        """(kind, key expressions) for each kind it has any of."""
        return [(f.name, getattr(self, f.name)) for f in fields(self) if getattr(self, f.name)]


ANY = "*"  # one chunk: an instance, a robot, a profile, a name; never '**'
_I, _R = InstanceKeys.every(), RobotKeys.every()


def _member(*roles: str) -> Part:
    """What a service says of itself, under each role its keys name: its status and its liveliness token."""
    return Part(put=tuple(_I.status(r, ANY) for r in roles), token=tuple(_I.alive(r, ANY) for r in roles))


def _with(a: Part, b: Part) -> Part:
    return Part(*(tuple(dict.fromkeys(getattr(a, f.name) + getattr(b, f.name))) for f in fields(Part)))


PARTS = {
    # services/boxes/platform.py (episodes.py: a task's reward), aibo.py: its token and status say "aibo"
    "platform": _with(_member("platform", "aibo"), Part(
        put=(_I.input, _I.applied, _I.reward, _I.episode, _R.state, _R.camera, _R.clock),
        answer=(_I.spaces, _R.spaces))),
    # services/boxes/chain.py: the upper instance's platform (its token), the lower one's input and spaces
    "chain": _with(_member("chain"), Part(
        put=(_I.input,), token=(_I.alive("platform", ANY),), answer=(_I.spaces,), ask=(_I.spaces, _R.spaces))),
    "handler": _with(_member("handler"), Part(put=(_R.handle,))),
    "perception": _with(_member("perception"), Part(put=(_I.input,), answer=(_I.spaces,), ask=(_R.spaces,))),
    # services/boxes/demonstrator.py, as --role teacher or --role default
    "teacher": _with(_member("teacher", "default"), Part(
        put=(_I.proposal("teacher", ANY), _I.proposal("default", ANY)), token=(_I.teaching(ANY),),
        ask=(_I.spaces,))),
    # services/boxes/learner.py: gaps filled from the arbitrator's recent pairs; a swap warms from a learner
    "learner": _with(_member("learner"), Part(
        put=(_I.proposal("learner", ANY),), answer=(_I.snapshot(ANY), _I.history(ANY)),
        ask=(_I.spaces, _I.train_recent, _I.snapshot(ANY), _I.history(ANY)))),
    "arbitrator": _with(_member("arbitrator"), Part(
        put=(_I.command, _I.train), token=(_I.commanding(ANY),), answer=(_I.train_recent,), ask=(_I.spaces,))),
    "recorder": _with(_member("recorder"), Part(ask=(_I.spaces, _R.spaces))),
    # a person: `dogged teach`, `dogged arena`, `dogged ps|logs|swap|down` (services/supervisor/commands.py),
    # `dogged snapshot learner FILE` (services/export: the student's state, read) and `dogged ui` (services/ui),
    # whose token and status say "ui" and which teleoperates as a teacher
    "operator": _with(_member("ui"), Part(
        put=(_I.teach, _I.record, _R.arena, _I.proposal("teacher", ANY)), token=(_I.teaching(ANY),),
        ask=(_I.spaces, EVERY_VERB, _I.snapshot(ANY)))),
    # services/supervisor: its verbs, its token, the learner a hot-swap selects (services/supervisor/swap.py)
    "supervisor": Part(put=(_I.select_learner,), token=(supervisor_token(ANY),),
                       answer=(EVERY_VERB,)),
}


def _router() -> Part:
    """The router forwards what its own access control let in (a linked router's too): whatever any role
    may say; it says only that it is up (services/boxes/router.py: its profile's token, else ROUTER)."""
    every = Part(token=(ROUTER, EVERY_ROUTER))
    for part in PARTS.values():
        every = _with(every, part)
    return every


PARTS["router"] = _router()
