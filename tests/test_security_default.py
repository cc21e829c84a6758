"""Secure by default on a shared machine (issue 30): a profile that names no zenoh.security runs with this
user's own identities, made at its first `dogged up` in a folder only this user enters; this user's verbs
find them with no flag, and anyone else on the machine (another user's process, or one without those
identities) gets nothing: no teaching switched, no stop, not even a connection."""
import json
import os
import stat
import subprocess
import sys

import pytest
import zenoh

from rigs.harness import REPO, dogged, free_port, wait_until
from services.bus.config import zenoh_config
from services.certificates import make_certs
from services.own_identities import home, identities_dir, person
from tests.test_supervisor import PROFILE, ps

pytestmark = pytest.mark.live

NOBODY = 65534  # Debian's nobody: another user of this machine, with no home


def mode(path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


def teaching(endpoint: str) -> list[str]:
    """The teaching tokens alive on the profile's bus, heard over this user's own identity."""
    with zenoh.open(zenoh_config(connect=[endpoint], mode="client", give_up_after=10)) as session:
        return sorted(str(r.ok.key_expr) for r in session.liveliness().get("dl/main/alive/teaching/*", timeout=5)
                      if r.ok is not None)


def verb(*args, env=None, user=None):
    return subprocess.run([sys.executable, "-m", "services.cli", *args], cwd=REPO, capture_output=True, text=True,
                          timeout=60, env=env, user=user)


@pytest.fixture
def own_profile(tmp_path):
    """The supervisor test's profile, which names no security, up on a free port given as tcp/."""
    path = tmp_path / "suptest.toml"
    path.write_text(PROFILE.format(logs=tmp_path / "logs", state=tmp_path / "state"))
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sup = dogged("up", str(path), "--router", endpoint, "--quiet", log=tmp_path / "supervisor.log")
    try:
        wait_until(lambda: (rows := ps(endpoint)) and all(r["state"] == "ready" for r in rows.values()), 90,
                   "every service ready")
        yield endpoint, sup
    finally:
        verb("--connect", endpoint, "down")
        sup.wait(60)


def still_teaching_and_up(endpoint: str, sup) -> None:
    assert sup.poll() is None, "the profile stopped"
    assert teaching(endpoint) == ["dl/main/alive/teaching/teacher"]
    assert ps(endpoint)["teacher"]["state"] == "ready"


def test_the_first_up_makes_this_users_identities_private_and_the_verbs_find_them(own_profile):
    endpoint, _ = own_profile
    here = home()
    assert mode(here) == 0o700 and mode(identities_dir()) == 0o700
    keys = sorted(here.rglob("*.key"))
    assert keys and all(mode(k) == 0o600 for k in keys)
    assert not list(identities_dir().glob("*.key")) and (here / "identities-ca" / "ca.key").is_file()
    assert (identities_dir() / f"operator.{person()}" / f"operator.{person()}.key").is_file()
    record = json.loads((here / "up" / f"127.0.0.1-{endpoint.rsplit(':', 1)[1]}.json").read_text())
    assert record["router"] == endpoint.replace("tcp/", "tls/") and record["security"] == str(identities_dir())
    # the tcp/ endpoint a person types is found as the tls/ one the profile runs on, as this user's operator
    rows = ps(endpoint)
    assert set(rows) == {"router", "recorder", "platform", "teacher", "learner", "arbitrator"}


def test_a_process_without_this_users_identities_gets_nothing(own_profile, tmp_path):
    """Before issue 30 the same `teach off` and `down` from anyone on the machine were obeyed."""
    endpoint, sup = own_profile
    stranger = {**os.environ, "DOGGED_HOME": str(tmp_path / "stranger")}
    for args in (("teach", "off"), ("down",)):
        said = verb("--connect", endpoint, "--wait", "3", *args, env=stranger)
        assert said.returncode == 1 and "cannot reach the router" in said.stderr, said.stderr
    # a CA of its own, an operator's certificate of it, over TLS to the right port: refused at the handshake
    make_certs(tmp_path / "eve", ["operator.eve"])
    forged = {**stranger, "DOGGED_SECURITY": str(tmp_path / "eve" / "operator.eve"), "DOGGED_IDENTITY": "operator.eve"}
    said = verb("--connect", endpoint.replace("tcp/", "tls/"), "--wait", "3", "down", env=forged)
    assert said.returncode == 1 and "cannot reach the router" in said.stderr, said.stderr
    still_teaching_and_up(endpoint, sup)


def test_another_user_of_the_machine_can_read_none_of_this_users_identities(own_profile):
    """What keeps another user's process out is that it cannot show this user's identities (the test above:
    without them it gets nothing): tried as that user, every key, certificate and record is unreadable."""
    if os.geteuid() != 0:
        pytest.skip("only root can start a process as another user (here: to try reading as user nobody)")
    files = sorted(p for p in home().rglob("*") if p.is_file())
    assert any(p.suffix == ".key" for p in files) and any(p.parent.name == "up" for p in files)
    for path in files:
        tried = subprocess.run(["cat", str(path)], user=NOBODY, capture_output=True, text=True)
        assert tried.returncode != 0 and "Permission denied" in tried.stderr, f"user {NOBODY} read {path}"
    listed = subprocess.run(["ls", str(identities_dir())], user=NOBODY, capture_output=True, text=True)
    assert listed.returncode != 0 and "Permission denied" in listed.stderr


def test_an_observer_on_the_secured_bus_writes_nothing_of_zenoh_on_its_stdout(own_profile):
    """A peer that is not a service (a benchmark's observer) enforces access control as every peer does, but
    no supervisor reads its stdout: Zenoh's lines of who linked to it went into a benchmark's output, whose
    last line must be its JSON figures."""
    endpoint, _ = own_profile
    observer = ("import time, zenoh; from services.bus.config import zenoh_config\n"
                f"with zenoh.open(zenoh_config(connect=['{endpoint}'], mode='peer')) as s:\n"
                "    s.declare_subscriber('dl/main/**', lambda sample: None); time.sleep(3)\n"
                "print('END')")
    done = subprocess.run([sys.executable, "-c", observer], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout == "END\n", done.stdout[:2000]
