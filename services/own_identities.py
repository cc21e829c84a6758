"""Secure by default on a shared machine (issue 30): a profile that names no `zenoh.security` runs with
identities too, made at its first `dogged up` in a folder only this user enters, and found there by this
user's verbs and boxes with no flag.

    ~/.local/state/dogged/           0700 ($DOGGED_HOME, else $XDG_STATE_HOME/dogged)
      identities/                    a `dogged certs` directory: ca.pem, a folder per identity
      identities-ca/                 its CA (ca.key 0600), which `dogged certs` signs from
      up/127.0.0.1-7447.json         a running profile's router: its endpoint, security, supervisor pid
      pages/8080.url                 a page's address with its token, while its ui runs

Loopback lets every local user reach a port; only this user can read these keys, so another user's
process on the same machine is refused by the router's mutual TLS and gets nothing.
"""
from __future__ import annotations

import contextlib
import fcntl
import getpass
import json
import os
import re
import stat
from pathlib import Path

from services.certificates import make_certs, private_folder, write_private
from services.security import ROLES
from services.waiting import poll

HOME_ENV = "DOGGED_HOME"
ROLE_ENV = "DOGGED_ROLE"  # the role a box run by hand shows (`dogged run <box>` sets it); else operator
SECURE_SCHEME = "tls"


class NotPrivate(ValueError):
    """The per-user folder is not this user's alone: nothing in it is trusted or written."""


def home() -> Path:
    """This user's dogged folder (not made here)."""
    given = os.environ.get(HOME_ENV)
    if given:
        return Path(given).absolute()
    state = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(state).absolute() / "dogged"


def private_home() -> Path:
    """home(), made 0700 if missing; NotPrivate when it exists but another user owns it or others may enter."""
    folder = private_folder(home())
    info = folder.stat()
    if info.st_uid != os.geteuid() or stat.S_IMODE(info.st_mode) & 0o077:
        raise NotPrivate(f"{folder}: must be yours alone (owner uid {info.st_uid}, mode "
                         f"{stat.S_IMODE(info.st_mode):o}); `chmod 700 {folder}` if it is yours")
    return folder


def identities_dir() -> Path:
    return home() / "identities"


def person() -> str:
    """This user's name as an identity's name: lowercase letters, digits, '-' and '_'."""
    try:
        login = getpass.getuser()
    except (KeyError, OSError):
        login = str(os.geteuid())
    name = re.sub(r"[^a-z0-9_-]", "-", login.lower()).lstrip("-_")[:64]
    return name or f"uid{os.geteuid()}"


def own_identities() -> list[str]:
    """The identities this user's verbs and hand-run boxes show: one per role (`operator.<user>` for the
    verbs, `teacher.<user>` for a demonstrator run by hand, ...), never the router's or a supervisor's."""
    return [f"{role}.{person()}" for role in ROLES if role not in ("router", "supervisor")]


def ensure_identities(identities: list[str]) -> Path:
    """The per-user `dogged certs` directory holding `identities` and this user's own, made where missing
    (under a lock: two first `up`s at once make one CA)."""
    folder = private_home()
    with open(folder / ".lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        make_certs(identities_dir(), list(dict.fromkeys([*identities, *own_identities()])),
                   ca_dir=folder / "identities-ca")
    return identities_dir()


def secured_endpoint(endpoint: str) -> str:
    """A loopback tcp/ endpoint as the tls/ one the same port takes when security is on."""
    scheme, _, rest = endpoint.partition("/")
    return f"{SECURE_SCHEME}/{rest}" if scheme == "tcp" else endpoint


def _replace_private(path: Path, data: bytes) -> Path:
    """`path` written anew, this user's alone from its first byte (one left by a process gone is replaced)."""
    with contextlib.suppress(FileNotFoundError):
        path.unlink()
    write_private(path, data)
    return path


def _record_path(endpoint: str) -> Path:
    host_port = endpoint.split("/", 1)[-1].replace("[", "").replace("]", "").replace(":", "-")
    return home() / "up" / f"{host_port}.json"


def announce(endpoint: str, security: Path | None, roster: list[str], profile: str) -> Path:
    """Say, for this user's verbs, that a profile's router runs at `endpoint`, with which security and
    roster."""
    private_folder(private_home() / "up")
    record = {"router": endpoint, "security": str(security) if security else None, "roster": roster,
              "profile": profile, "pid": os.getpid()}
    return _replace_private(_record_path(endpoint), json.dumps(record).encode())


def withdraw(endpoint: str) -> None:
    path = _record_path(endpoint)
    with contextlib.suppress(FileNotFoundError, json.JSONDecodeError, OSError):
        if json.loads(path.read_text()).get("pid") == os.getpid():
            path.unlink()


def running_at(endpoint: str) -> dict | None:
    """This user's running profile whose router holds `endpoint`'s host and port (any scheme), or None:
    none, its supervisor gone, or the folder not this user's alone (then nothing in it is trusted)."""
    try:
        private = home().is_dir() and private_home()
        path = _record_path(endpoint)
        if not private or not path.is_file() or path.stat().st_uid != os.geteuid():
            return None
        record = json.loads(path.read_text())
        os.kill(int(record["pid"]), 0)
    except (NotPrivate, OSError, ValueError, KeyError, TypeError):  # ProcessLookupError is an OSError
        return None
    return record if isinstance(record.get("router"), str) else None


def identity_for_connecting(endpoint: str) -> tuple[str, Path, str, list[str]] | None:
    """(the endpoint to connect to, the identity's folder, the identity, the profile's roster) when this
    user's profile at `endpoint` runs secured and this user has an identity of the role in its directory
    ($DOGGED_ROLE, else operator); None otherwise."""
    record = running_at(endpoint)
    if record is None or not record.get("security"):
        return None
    cn = f"{os.environ.get(ROLE_ENV, 'operator')}.{person()}"
    folder = Path(record["security"]) / cn
    if not (folder / f"{cn}.key").is_file():
        return None
    roster = record.get("roster")
    if not isinstance(roster, list) or not all(isinstance(member, str) for member in roster):
        return None
    return record["router"], folder, cn, roster


# the page's token for as long as its profile runs: `dogged up` makes one and gives it to its ui, so a ui
# restarted (killed, crashed) asks the same, and a page a person has open reconnects by itself
PAGE_TOKEN_ENV = "DOGGED_PAGE_TOKEN"


def note_page(port: int, address: str) -> Path | None:
    """Keep a page's address with its token where only this user reads it; None if the folder is not
    this user's alone (then the console of `dogged up` is the one place it is shown)."""
    try:
        return _replace_private(private_folder(private_home() / "pages") / f"{port}.url", address.encode())
    except (NotPrivate, OSError):
        return None


def forget_page(address: str | None) -> None:
    if address:
        port = address.rstrip("/").rsplit(":", 1)[-1]
        with contextlib.suppress(OSError):
            (home() / "pages" / f"{port}.url").unlink()


def page_address(port: int, wait_s: float = 0.0) -> str:
    """The address a person opens for this user's page on `port`: with its token when the page needs one
    (waiting up to `wait_s` for a page just started to say it); without, when it needs none."""
    path = home() / "pages" / f"{port}.url"

    def kept() -> str | None:
        with contextlib.suppress(OSError):
            return path.read_text()
        return None
    return poll(kept, wait_s) or f"http://localhost:{port}/"
