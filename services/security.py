"""Who may say what on the bus: mutual TLS identities and Zenoh access control (issue 12).

Every process that joins a secured router shows a certificate signed by the deployment's own CA
(`dogged certs`); anyone else cannot connect. A certificate's common name is its identity,
`<role>.<name>` (`teacher.alice`, `platform.aibo`, `operator.bob`), and the router's access control
lets each role say only its part, as the paper's Figure 1 draws it:

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

The recorder owns nothing: it only listens and asks. Everything else (subscribing, status, querying
the owners) stays open to every identity. Services join as peers that link to each other directly
over mutual TLS (a hop fewer than through the router), so every peer enforces the same access
control on what reaches it, as the router does on what its clients send; what the router forwards
has passed its check.
"""
from __future__ import annotations

import datetime
import ipaddress
import json
import re
from pathlib import Path

from bus_schema.keys import SUPERVISOR, InstanceKeys, RobotKeys

ROLES = ("platform", "chain", "handler", "perception", "teacher", "learner", "arbitrator", "recorder", "operator",
         "supervisor", "router")
_IDENTITY = re.compile(r"^([a-z]+)\.([a-z0-9][a-z0-9_-]{0,63})$")

# (what, key expressions, the roles that alone may do it); ACL message kinds of Zenoh 1.x
_PUT, _ANSWER, _TOKEN, _ASK = ["put", "delete"], ["declare_queryable", "reply"], ["liveliness_token"], ["query"]
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


def access_control(identities: list[str]) -> dict:
    """Zenoh's `access_control` section: each owned flow denied, on ingress at the router, to every
    identity whose role does not own it."""
    by_role: dict[str, list[str]] = {}
    for cn in identities:
        by_role.setdefault(role_of(cn), []).append(cn)
    rules, policies = [], []
    for i, (_what, messages, keys, owners) in enumerate(OWNERS):
        # the router forwards what its own access control let in: a peer takes that from it
        others = [role for role in by_role if role not in owners and role != "router"]
        if not others:
            continue
        rules.append({"id": f"r{i}", "permission": "deny", "flows": ["ingress"], "messages": messages,
                      "key_exprs": keys})
        policies.append({"id": f"p{i}", "rules": [f"r{i}"], "subjects": [f"s-{role}" for role in others]})
    subjects = [{"id": f"s-{role}", "cert_common_names": cns} for role, cns in sorted(by_role.items())]
    return {"enabled": True, "default_permission": "allow", "rules": rules, "subjects": subjects,
            "policies": policies}


def tls_section(directory: Path, cn: str) -> dict:
    """`transport/link/tls` for identity `cn`: its key and certificate, the CA, mutual TLS."""
    directory = Path(directory)
    key, cert, ca = directory / f"{cn}.key", directory / f"{cn}.pem", directory / "ca.pem"
    for path in (key, cert, ca):
        if not path.is_file():
            raise FileNotFoundError(f"{path}: no such file (make it with `dogged certs {directory} ...`)")
    return {"root_ca_certificate": str(ca), "enable_mtls": True, "verify_name_on_connect": False,
            "listen_private_key": str(key), "listen_certificate": str(cert),
            "connect_private_key": str(key), "connect_certificate": str(cert)}


def secure(conf, directory: Path, cn: str, enforce: bool = False) -> None:
    """Turn a zenoh.Config into a TLS one for `cn`; a router or a peer (which other peers reach
    directly) also enforces the access control of every identity in the directory."""
    conf.insert_json5("transport/link/tls", json.dumps(tls_section(directory, cn)))
    if enforce:
        conf.insert_json5("access_control", json.dumps(access_control(identities_in(directory))))


def identities_in(directory: Path) -> list[str]:
    return sorted(p.stem for p in Path(directory).glob("*.pem") if p.name != "ca.pem")


# --- certificates ------------------------------------------------------------------------------
def certificate(cn: str, key, valid_days: int, extensions, issuer=None):
    """An X.509 certificate for `key`, named `cn`, signed by `issuer` = (its name, its key), or by
    itself; valid from five minutes ago (clocks differ) for `valid_days`."""
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes
    from cryptography.x509.oid import NameOID

    now = datetime.datetime.now(datetime.UTC)
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, cn)])
    issuer_name, issuer_key = issuer or (name, key)
    builder = (x509.CertificateBuilder().subject_name(name).issuer_name(issuer_name)
               .public_key(key.public_key()).serial_number(x509.random_serial_number())
               .not_valid_before(now - datetime.timedelta(minutes=5))
               .not_valid_after(now + datetime.timedelta(days=valid_days)))
    for extension, critical in extensions:
        builder = builder.add_extension(extension, critical=critical)
    return builder.sign(issuer_key, hashes.SHA256())


def key_pem(key) -> bytes:
    """A private key as unencrypted PKCS#8 PEM (kept in a 0600 file, or never on disk)."""
    from cryptography.hazmat.primitives import serialization
    return key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                             serialization.NoEncryption())


def make_certs(directory: Path, identities: list[str], days: int = 365) -> list[Path]:
    """A CA (kept, or made once) and a key and certificate per identity, in `directory`."""
    from cryptography import x509
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import ExtendedKeyUsageOID

    for cn in identities:  # all checked before anything is written
        role_of(cn)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)

    def write(key, cert, stem: str) -> Path:
        key_path, cert_path = directory / f"{stem}.key", directory / f"{stem}.pem"
        key_path.write_bytes(key_pem(key))
        key_path.chmod(0o600)
        cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
        return cert_path

    if (directory / "ca.key").exists() and (directory / "ca.pem").exists():
        ca_key = serialization.load_pem_private_key((directory / "ca.key").read_bytes(), None)
        ca_cert = x509.load_pem_x509_certificate((directory / "ca.pem").read_bytes())
    else:
        ca_key = ec.generate_private_key(ec.SECP256R1())
        ca_cert = certificate("dogged-ca", ca_key, 10 * days, [(x509.BasicConstraints(ca=True, path_length=0), True)])
        write(ca_key, ca_cert, "ca")
    loopback = [x509.DNSName("localhost"), x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]
    leaf = [(x509.SubjectAlternativeName(loopback), False),
            (x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]), False),
            (x509.BasicConstraints(ca=False, path_length=None), True)]
    written = []
    for cn in identities:
        key = ec.generate_private_key(ec.SECP256R1())
        written.append(write(key, certificate(cn, key, days, leaf, issuer=(ca_cert.subject, ca_key)), cn))
    return written

