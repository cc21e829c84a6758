"""Who may say what on the bus: mutual TLS identities and Zenoh access control (issues 12 and 30).

Every process that joins a secured router shows a certificate signed by the deployment's own CA
(`dogged certs`, services/certificates.py); anyone else cannot connect. A certificate's common name is
its identity, `<role>.<name>` (`teacher.alice`, `platform.aibo`, `operator.bob`). Access control denies
by default: only the identities on the deployment's roster (the identity folders of its `dogged certs`
directory, read once by `dogged up` and handed to every process it starts) get anything, and each
role says only its part, as the paper's Figure 1 draws it:

| who | alone may |
|---|---|
| platform | publish inputs, applied commands, robot state, camera and clock; answer `spaces` |
| chain, perception | publish an instance's inputs; answer its `spaces` |
| handler | publish the robot's handle |
| teacher | publish teacher proposals; hold teaching tokens |
| learner | publish learner proposals; answer snapshot and history; hold learner tokens |
| arbitrator | publish commands and training pairs; answer recent pairs; hold commanding tokens |
| operator (a person), supervisor | switch teaching, select the learner, rebuild the arena, call the supervisor |
| operator (a person, `dogged ui`) | also teach by teleoperation: teacher proposals and teaching tokens |
| supervisor | answer the supervisor's verbs |
| router (`router.router` only) | everything: a router forwards only what its own access control let in |

The recorder owns nothing: it only listens and asks. Everything else (subscribing, status, querying
the owners) is open to every identity on the roster, and to no other: a certificate of the same CA
made after the roster was read, or a `router.*` other than `router.router`, matches no subject and
gets nothing, neither in nor out (services/refusals.py counts those refusals). Services join as peers
that link to each other directly over mutual TLS (a hop fewer than through the router), so every peer
enforces the same access control on what reaches it, as the router does on what its clients send.
"""
from __future__ import annotations

import ipaddress
import json
import os
import re
from pathlib import Path

from bus_schema.keys import SUPERVISOR, InstanceKeys, RobotKeys

ROUTER_IDENTITY = "router.router"  # the one identity of the router role
ROSTER_ENV = "DOGGED_ROSTER"  # the roster `dogged up` read, handed to every process it starts
ROLES = ("platform", "chain", "handler", "perception", "teacher", "learner", "arbitrator", "recorder", "operator",
         "supervisor", "router")
_IDENTITY = re.compile(r"^([a-z]+)\.([a-z0-9][a-z0-9_-]{0,63})$")

# (what, key expressions, the roles that alone may do it); ACL message kinds of Zenoh 1.x
_PUT, _ANSWER, _TOKEN, _ASK = ["put", "delete"], ["declare_queryable", "reply"], ["liveliness_token"], ["query"]
_EVERY_MESSAGE = [*_PUT, *_ANSWER, *_TOKEN, *_ASK, "declare_subscriber", "declare_liveliness_subscriber",
                  "liveliness_query"]
_I, _R = InstanceKeys.every(), RobotKeys.every()  # every key below comes from bus_schema
OWNERS = (
    # perception turns the camera into a DL instance's input (ball seeking): it says the input and its spaces
    ("inputs", _PUT, [_I.input], ("platform", "chain", "perception")),
    ("spaces", _ANSWER, [_I.spaces], ("platform", "chain", "perception")),
    ("robot streams", _PUT, [_R.state, _R.camera, _R.clock], ("platform",)),
    ("robot spaces", _ANSWER, [_R.spaces], ("platform",)),
    ("handle", _PUT, [_R.handle], ("handler",)),
    # a person at the page (dogged ui, an operator) teaches by teleoperation: a teacher's proposals and token
    ("teacher proposals", _PUT, [_I.proposal("teacher", "**")], ("teacher", "operator")),
    ("default proposals", _PUT, [_I.proposal("default", "**")], ("teacher",)),
    ("teaching tokens", _TOKEN, [_I.teaching("**")], ("teacher", "operator")),
    ("teacher tokens", _TOKEN, [_I.alive("teacher", "**")], ("teacher",)),
    ("learner proposals", _PUT, [_I.proposal("learner", "**")], ("learner",)),
    ("learner state", _ANSWER, [_I.snapshot("*"), _I.history("*")], ("learner",)),
    ("learner tokens", _TOKEN, [_I.alive("learner", "**")], ("learner",)),
    ("applied commands", _PUT, [_I.applied], ("platform",)),
    ("commands", _PUT, [_I.command, _I.train], ("arbitrator",)),
    ("recent pairs", _ANSWER, [_I.train_recent], ("arbitrator",)),
    ("commanding tokens", _TOKEN, [_I.commanding("**"), _I.alive("arbitrator", "**")], ("arbitrator",)),
    ("operator verbs", _PUT, [_I.teach, _I.record, _I.select_learner, _R.arena], ("operator", "supervisor")),
    ("supervisor verbs", _ASK, [f"{SUPERVISOR}/**"], ("operator", "supervisor")),
    ("supervisor answers", _ANSWER, [f"{SUPERVISOR}/**"], ("supervisor",)),
)


def is_loopback(endpoint: str) -> bool:
    """Whether a Zenoh endpoint (tcp/127.0.0.1:7447, tls/[::1]:7447, ...) listens on loopback only."""
    host = endpoint.split("/", 1)[-1].rsplit(":", 1)[0].strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # a host name: whoever resolves it may reach it


def identity(role: str, name: str) -> str:
    """The common name of a certificate: `<role>.<name>`, or ValueError."""
    cn = f"{role}.{name}"
    role_of(cn)
    return cn


def role_of(cn: str) -> str:
    """The role of identity `cn` (<role>.<name>), or ValueError saying what an identity is."""
    match = _IDENTITY.match(cn)
    if match is None or match.group(1) not in ROLES:
        raise ValueError(f"identity {cn!r} is not <role>.<name>: role must be one of {', '.join(ROLES)}, "
                         f"name lowercase letters, digits, '-' or '_'")
    return match.group(1)


def known(roster: list[str]) -> list[str]:
    """The identities of a roster that access control names: each checked; a router's only if it is the
    router's own (any other `router.*` gets nothing, as a stranger)."""
    return [cn for cn in roster if role_of(cn) != "router" or cn == ROUTER_IDENTITY]


def access_control(roster: list[str]) -> dict:
    """Zenoh's `access_control` section: denied by default; each known identity of the roster allowed
    everything, in and out, but the owned flows (OWNERS) its role does not own, which it may not send."""
    by_role: dict[str, list[str]] = {}
    for cn in known(roster):
        by_role.setdefault(role_of(cn), []).append(cn)
    if not by_role:
        raise ValueError("an empty roster would shut every process out, the router included")
    rules = [{"id": "known", "permission": "allow", "flows": ["ingress", "egress"], "messages": _EVERY_MESSAGE,
              "key_exprs": ["**"]}]
    policies = [{"id": "p-known", "rules": ["known"], "subjects": [f"s-{role}" for role in sorted(by_role)]}]
    for i, (_what, messages, keys, owners) in enumerate(OWNERS):
        others = [role for role in by_role if role not in owners and role != "router"]
        if not others:
            continue
        rules.append({"id": f"r{i}", "permission": "deny", "flows": ["ingress"], "messages": messages,
                      "key_exprs": keys})
        policies.append({"id": f"p{i}", "rules": [f"r{i}"], "subjects": [f"s-{role}" for role in others]})
    subjects = [{"id": f"s-{role}", "cert_common_names": cns} for role, cns in sorted(by_role.items())]
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects,
            "policies": policies}


def identity_folder(directory: Path, cn: str) -> Path:
    """Where identity `cn`'s files are: its folder in a `dogged certs` directory, or `directory` itself
    when it is that folder (all a person or a service is given)."""
    directory = Path(directory)
    return directory / cn if (directory / cn).is_dir() else directory


def tls_section(directory: Path, cn: str) -> dict:
    """`transport/link/tls` for identity `cn`: its key and certificate, the CA, mutual TLS."""
    folder = identity_folder(directory, cn)
    key, cert, ca = folder / f"{cn}.key", folder / f"{cn}.pem", folder / "ca.pem"
    for path in (key, cert, ca):
        if not path.is_file():
            raise FileNotFoundError(f"{path}: no such file (make it with `dogged certs DIR --identity {cn}`)")
    return {"root_ca_certificate": str(ca), "enable_mtls": True, "verify_name_on_connect": False,
            "listen_private_key": str(key), "listen_certificate": str(cert),
            "connect_private_key": str(key), "connect_certificate": str(cert)}


def secure(conf, directory: Path, cn: str, roster: list[str] | None = None) -> None:
    """Turn a zenoh.Config into a TLS one for `cn`; with a roster (a router, or a peer, which other peers
    reach directly) it also enforces the access control of that roster."""
    conf.insert_json5("transport/link/tls", json.dumps(tls_section(directory, cn)))
    if roster is not None:
        conf.insert_json5("access_control", json.dumps(access_control(roster)))


def identities_in(directory: Path) -> list[str]:
    """The identities of a `dogged certs` directory now: its folders holding their own certificate."""
    return sorted(p.parent.name for p in Path(directory).glob("*/*.pem") if p.stem == p.parent.name)


def roster(directory: Path) -> list[str]:
    """The identities this process's access control knows: $DOGGED_ROSTER (what `dogged up` read once and
    handed to every process it starts), else those of `directory` as they are now."""
    given = os.environ.get(ROSTER_ENV)
    names = [cn for cn in given.split(",") if cn] if given else identities_in(directory)
    if not names:
        raise ValueError(f"no roster: a router or a peer enforcing access control needs ${ROSTER_ENV} (`dogged up` "
                         f"sets it) or a `dogged certs` directory, and {directory} holds no identity's folder")
    return names
