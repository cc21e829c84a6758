"""Who may say what on the bus: mutual TLS identities and Zenoh access control (issues 12 and 30).

Every process that joins a secured router shows a certificate signed by the deployment's own CA
(`dogged certs`, services/certificates.py); anyone else cannot connect. A certificate's common name is
its identity, `<role>.<name>` (`teacher.alice`, `platform.aibo`, `operator.bob`). Access control denies
by default: only the identities on the deployment's roster (the identity folders of its `dogged certs`
directory, read once by `dogged up` and handed to every process it starts) get anything, and each is
allowed exactly its role's part (services/permissions.py; `i` is any instance, `r` any robot, `*` any
name or profile, and `{a,b}` either):

| role | may | key expressions |
|---|---|---|
| platform | put | `dl/i/{input,applied,reward,episode}`, `robot/r/{state,camera,clock}` |
| platform | put | `dl/i/status/{platform,aibo}/*` |
| platform | token | `dl/i/alive/{platform,aibo}/*` |
| platform | answer | `dl/i/spaces`, `robot/r/spaces` |
| chain | put | `dl/i/input`, `dl/i/status/chain/*` |
| chain | token | `dl/i/alive/{chain,platform}/*` |
| chain | answer | `dl/i/spaces` |
| chain | ask | `dl/i/spaces`, `robot/r/spaces` |
| handler | put | `robot/r/handle`, `dl/i/status/handler/*` |
| handler | token | `dl/i/alive/handler/*` |
| perception | put | `dl/i/input`, `dl/i/status/perception/*` |
| perception | token | `dl/i/alive/perception/*` |
| perception | answer | `dl/i/spaces` |
| perception | ask | `robot/r/spaces` |
| teacher | put | `dl/i/proposal/{teacher,default}/*`, `dl/i/status/{teacher,default}/*` |
| teacher | token | `dl/i/alive/{teacher,default,teaching}/*` |
| teacher | ask | `dl/i/spaces` |
| learner | put | `dl/i/proposal/learner/*`, `dl/i/status/learner/*` |
| learner | token | `dl/i/alive/learner/*` |
| learner | answer | `dl/i/learner/*/{snapshot,history}` |
| learner | ask | `dl/i/spaces`, `dl/i/train/recent`, `dl/i/learner/*/{snapshot,history}` |
| arbitrator | put | `dl/i/{command,train}`, `dl/i/status/arbitrator/*` |
| arbitrator | token | `dl/i/alive/{arbitrator,commanding}/*` |
| arbitrator | answer | `dl/i/train/recent` |
| arbitrator | ask | `dl/i/spaces` |
| recorder | put | `dl/i/status/recorder/*` |
| recorder | token | `dl/i/alive/recorder/*` |
| recorder | ask | `dl/i/spaces`, `robot/r/spaces` |
| operator | put | `dl/i/{teach,record}`, `robot/r/arena`, `dl/i/proposal/teacher/*`, `dl/i/status/ui/*` |
| operator | token | `dl/i/alive/{ui,teaching}/*` |
| operator | ask | `dl/i/spaces`, `dogged/supervisor/*/*`, `dl/i/learner/*/snapshot` |
| supervisor | put | `dl/i/arbitrator/select` |
| supervisor | token | `dogged/supervisor/*` |
| supervisor | answer | `dogged/supervisor/*/*` |
| router | each | every role's part above (it forwards what its own access control let in) |
| router | token | also `dogged/router`, `dogged/router/*` |

Put is Zenoh's put (nobody deletes), token a liveliness token, answer a queryable and its replies, ask a
query. An operator is a person (the `dogged` verbs; `dogged ui`, which teleoperates as a teacher); only
`router.router` is of the router role. Zenoh allows a message only when an allowed key expression
includes its key, so a wildcard that reaches past a role's part (`dl/**`, `**`, `dl/main/alive/**`) is
refused whole. Listening (subscribers, liveliness subscribers, liveliness queries) is open to every
identity on the roster, and whatever passed a process's ingress may go out to any of them; to no other:
a certificate of the same CA made after the roster was read, or a `router.*` other than `router.router`,
matches no subject and gets nothing, neither in nor out (services/refusals.py counts those refusals).
Services join as peers that link to each other directly over mutual TLS (a hop fewer than through the
router), so every peer enforces the same access control on what reaches it, as the router does on what
its clients send.
"""
from __future__ import annotations

import ipaddress
import json
import os
import re
from pathlib import Path

from services.permissions import PARTS

ROUTER_IDENTITY = "router.router"  # the one identity of the router role
ROSTER_ENV = "DOGGED_ROSTER"  # the roster `dogged up` read, handed to every process it starts
ROLES = tuple(PARTS)  # every role of an identity (services/permissions.py)
_IDENTITY = re.compile(r"^([a-z]+)\.([a-z0-9][a-z0-9_-]{0,63})$")

# Zenoh 1.x's ACL messages for each kind of a role's part (services/permissions.py)
MESSAGES = {"put": ["put"], "token": ["liveliness_token"], "answer": ["declare_queryable", "reply"],
            "ask": ["query"]}
# listening, in (a member's subscriber) and out (passed on to the others); and every part's messages out to
# members. Each egress is needed: a secured profile of peers never gets ready without that of listening or
# of declare_queryable, and tests/test_security_parts.py fails without that of put, token, reply or query
_LISTEN = ["declare_subscriber", "declare_liveliness_subscriber", "liveliness_query"]
_DELIVERED = [m for kind in MESSAGES.values() for m in kind]


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
    """Zenoh's `access_control` section: denied by default; each known identity of the roster may listen,
    be sent what passed ingress, and say exactly its role's part (PARTS), each kind of message on its
    own key expressions."""
    by_role: dict[str, list[str]] = {}
    for cn in known(roster):
        by_role.setdefault(role_of(cn), []).append(cn)
    if not by_role:
        raise ValueError("an empty roster would shut every process out, the router included")
    members = [f"s-{role}" for role in sorted(by_role)]
    rules = [{"id": "listen", "permission": "allow", "flows": ["ingress", "egress"], "messages": _LISTEN,
              "key_exprs": ["**"]},
             # a message is checked where it comes in (the router, or a peer linked directly): going out to a
             # member, whatever passed there is delivered
             {"id": "deliver", "permission": "allow", "flows": ["egress"], "messages": _DELIVERED,
              "key_exprs": ["**"]}]
    policies = [{"id": "p-members", "rules": ["listen", "deliver"], "subjects": members}]
    for role in sorted(by_role):
        ids = []
        for kind, keys in PARTS[role].kinds():
            ids.append(f"{role}-{kind}")
            rules.append({"id": ids[-1], "permission": "allow", "flows": ["ingress"], "messages": MESSAGES[kind],
                          "key_exprs": list(keys)})
        policies.append({"id": f"p-{role}", "rules": ids, "subjects": [f"s-{role}"]})
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
