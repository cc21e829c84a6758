"""A profile turns security on with one setting (issue 12): `dogged certs` makes its identities,
`dogged up` runs it over mutual TLS with access control, an operator's certificate steers it and a
teacher's cannot, a person at its page (the ui's operator certificate) switches teaching and drives;
and `dogged up` will not open a router beyond loopback without it."""
import asyncio
import collections
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from urllib.parse import urlsplit

import numpy as np
import pytest
import zenoh
from websockets.asyncio.client import connect

from bus_schema import Applied, Command, Input, TrainingPair, decode, encode
from rigs.harness import REPO, dogged, free_port, wait_until
from services.bus.config import zenoh_config
from services.certificates import make_certs
from services.own_identities import page_address
from services.security import is_loopback
from services.supervisor.profile import ProfileError, load_profile
from services.supervisor.supervisor import Supervisor
from tests.test_supervisor import PROFILE

# the supervisor test's profile (platform, teacher, learner, arbitrator), with a [zenoh] table added
ZENOH = """
[zenoh]
router = "{router}"
{security}
"""


# a person's page in the profile: its certificate is an operator's (BOX_ROLES)
PAGE = """
[services.ui]
box = "ui"
args = ["--http", "127.0.0.1:{port}", "--robot", "none"]
"""


def write_profile(tmp_path, router, certs="off", page_port=None):
    """certs: a `dogged certs` directory, "off" (no security: what these tests compare against), or None
    (no zenoh.security: this user's own identities, tests/test_security_default.py)."""
    path = tmp_path / "suptest.toml"
    security = f'security = "{certs}"' if certs else ""
    page = PAGE.format(port=page_port) if page_port else ""
    path.write_text(PROFILE.format(logs=tmp_path / "logs", state=tmp_path / "state") + page
                    + ZENOH.format(router=router, security=security))
    return path


async def at_the_page(port: int) -> list[str]:
    """A person at the page of a secured profile: teaching switched off and on, then driving; what the
    page showed at each step (the bus under access control carries the operator's every action)."""
    seen = []
    address = urlsplit(page_address(port, wait_s=30))  # a secured profile's page needs its token on loopback too
    async with connect(f"ws://{address.netloc}/ws?{address.query}") as ws:

        async def until(what, condition, send=None, timeout=30.0):
            deadline = asyncio.get_running_loop().time() + timeout
            while asyncio.get_running_loop().time() < deadline:
                if send:
                    await ws.send(send)
                try:
                    msg = await asyncio.wait_for(ws.recv(), 0.1)
                except TimeoutError:
                    continue
                if isinstance(msg, str) and (m := json.loads(msg))["type"] == "view" and condition(m):
                    seen.append(what)
                    return
            raise AssertionError(f"the page never showed {what}; saw {seen}")

        await until("the sine teacher teaching", lambda v: "teacher" in v["teaching"])
        await ws.send('{"op": "teach", "teacher": "teacher", "on": false}')
        await until("teaching switched off", lambda v: "teacher" not in v["teaching"])
        # driving: the page refreshes a held command every 100 ms, as the person's page does
        await until("the robot driven by the person", lambda v: (v["command"] or {}).get("source") == "teacher/person",
                    send='{"op": "teleop", "y": [0.5, -0.5]}')
        await ws.send('{"op": "teleop", "y": [null, null]}')
        await ws.send('{"op": "teach", "teacher": "teacher", "on": true}')
        await until("teaching switched on again", lambda v: "teacher" in v["teaching"])
    return seen


def cli(*args, identity=None, certs=None, timeout=60):
    env = dict(os.environ)
    if identity:
        env.update(DOGGED_SECURITY=str(certs), DOGGED_IDENTITY=identity)
    return subprocess.run([sys.executable, "-m", "services.cli", *args], cwd=REPO, capture_output=True, text=True,
                          timeout=timeout, env=env)


@pytest.mark.live
def test_a_secured_profile_runs_and_only_an_operator_steers_it(tmp_path):
    certs, endpoint, page_port = tmp_path / "certs", f"tls/127.0.0.1:{free_port()}", free_port()
    profile = write_profile(tmp_path, endpoint, certs, page_port)
    made = cli("certs", str(certs), "--profile", str(profile), "--identity", "operator.bob")
    assert made.returncode == 0, made.stderr
    assert "9 certificates" in made.stdout and (certs / "operator.ui" / "operator.ui.pem").is_file()
    sup = dogged("up", str(profile), "--quiet", log=tmp_path / "supervisor.log")
    try:
        def rows(identity="operator.bob"):
            out = cli("--connect", endpoint, "ps", "--json", identity=identity, certs=certs, timeout=30)
            return {r["name"]: r for r in json.loads(out.stdout)["services"]} if out.returncode == 0 else {}

        ready = wait_until(lambda: (r := rows()) and all(x["state"] == "ready" for x in r.values()) and r, 90,
                           "every service ready over TLS")
        assert set(ready) == {"router", "recorder", "platform", "teacher", "learner", "arbitrator", "ui"}
        learning = wait_until(lambda: rows().get("learner", {}).get("rates", {}).get("learned", 0) > 50, 30,
                              "the learner learning over TLS")
        assert learning
        assert asyncio.run(at_the_page(page_port)) == [
            "the sine teacher teaching", "teaching switched off", "the robot driven by the person",
            "teaching switched on again"]
        refused = cli("--connect", endpoint, "down", identity="teacher.teacher", certs=certs, timeout=30)
        assert refused.returncode != 0 and "did not answer" in refused.stderr
        assert rows()["arbitrator"]["state"] == "ready" and sup.poll() is None  # still up
        # a person without a certificate is told so, instead of waiting for ever
        stranger = cli("--connect", endpoint, "--wait", "3", "ps", timeout=30)
        assert stranger.returncode == 1 and "cannot reach the router" in stranger.stderr
        assert "DOGGED_SECURITY" in stranger.stderr
    finally:
        down = cli("--connect", endpoint, "down", identity="operator.bob", certs=certs)
        code = sup.wait(60)
    assert down.returncode == 0, down.stderr
    assert code == 0


FORGED = np.array([0.777, -0.777])


def forge(endpoint: str, certs, forger: str) -> collections.Counter:
    """`forger` answers 300 of the robot's inputs with commands of its making (each for the robot's
    newest tick, as the arbitrator's are) and sends 5 training pairs; what of them an operator on the
    roster heard, and how often the robot applied the forged command."""
    heard, newest = collections.Counter(), [0]

    def note(sample):
        key, raw = str(sample.key_expr), sample.payload.to_bytes()
        if key.endswith("/input"):
            newest[0] = decode(Input, raw, key).tick
        elif key.endswith("/applied"):
            heard["applied"] += bool(np.allclose(decode(Applied, raw, key).y, FORGED))
        elif key.endswith("/command"):
            heard["command"] += decode(Command, raw, key).source == "forged"
        else:
            heard["train"] += decode(TrainingPair, raw, key).source == "forged"

    def session(cn):
        return zenoh.open(zenoh_config(connect=[endpoint], mode="client", security=certs, identity=cn))
    with session("operator.bob") as bob, session(forger) as eve:
        held = [bob.declare_subscriber(f"dl/main/{k}", note) for k in ("input", "command", "applied", "train")]
        time.sleep(0.5)
        for i in range(300):
            eve.put("dl/main/command", encode(Command(newest[0], time.time(), FORGED, "teacher", "forged", 1.0)))
            if i % 60 == 0:
                eve.put("dl/main/train", encode(TrainingPair("forged", i, newest[0], np.zeros(4), FORGED, "forged")))
            time.sleep(0.01)
        time.sleep(0.5)
        del held
    return +heard


@pytest.mark.live
def test_a_certificate_made_after_up_gets_nothing_and_ps_counts_the_refusals(tmp_path):
    """Issue 30: the same CA signed teacher.eve, operator.mallory and handler.mallet (a role no service has)
    after `dogged up`: the router and every peer know only the roster read at `up`, so nothing they say
    is forwarded or applied, nothing they ask is answered, and `dogged ps` shows the router's refusals."""
    certs, endpoint = tmp_path / "certs", f"tls/127.0.0.1:{free_port()}"
    profile = write_profile(tmp_path, endpoint, certs)
    made = cli("certs", str(certs), "--profile", str(profile), "--identity", "operator.bob")
    assert made.returncode == 0, made.stderr
    sup = dogged("up", str(profile), "--quiet", log=tmp_path / "supervisor.log")
    try:
        def rows():
            out = cli("--connect", endpoint, "ps", "--json", identity="operator.bob", certs=certs, timeout=30)
            return {r["name"]: r for r in json.loads(out.stdout)["services"]} if out.returncode == 0 else {}

        wait_until(lambda: (r := rows()) and all(x["state"] == "ready" for x in r.values()) and r, 90,
                   "every service ready over TLS")
        late = cli("certs", str(certs), "--identity", "teacher.eve", "--identity", "operator.mallory",
                   "--identity", "handler.mallet")
        assert late.returncode == 0 and "restart it" in late.stdout, late.stderr
        assert forge(endpoint, certs, "teacher.eve") == {}
        for who, verb in (("operator.mallory", ["ps"]), ("operator.mallory", ["--profile", "suptest", "down"]),
                          ("handler.mallet", ["teach", "off"])):
            out = cli("--connect", endpoint, *verb, identity=who, certs=certs, timeout=30)
            assert out.returncode == 1, (who, verb, out.stdout)
        now = rows()
        assert now["router"]["refused"] == {"teacher.eve": 1, "operator.mallory": 2, "handler.mallet": 1}
        assert all(row.get("refused", {}) == {} for name, row in now.items() if name != "router")
        assert now["arbitrator"]["state"] == "ready" and sup.poll() is None  # still up
        shown = cli("--connect", endpoint, "ps", identity="operator.bob", certs=certs, timeout=30).stdout
        assert "refused: handler.mallet=1 operator.mallory=2 teacher.eve=1" in shown
    finally:
        down = cli("--connect", endpoint, "down", identity="operator.bob", certs=certs)
        code = sup.wait(60)
    assert down.returncode == 0, down.stderr
    assert code == 0


def test_each_service_is_handed_its_own_folder_and_the_roster_read_at_up(tmp_path):
    certs = tmp_path / "certs"
    path = write_profile(tmp_path, "tls/127.0.0.1:7447", certs)
    roster = load_profile(path, check_security=False).identities() + ["operator.bob"]
    make_certs(certs, roster)
    profile = load_profile(path)
    supervisor = Supervisor(profile, echo=False)
    make_certs(certs, ["teacher.eve"])  # after `up` read the roster
    for spec in profile.services:
        cn = profile.identity(spec)
        env = supervisor.secured(spec, cn).env
        assert sorted(p.name for p in Path(env["DOGGED_SECURITY"]).rglob("*.key")) == [f"{cn}.key"]
        assert sorted(env["DOGGED_ROSTER"].split(",")) == sorted(roster)
    assert "teacher.eve" in Supervisor(profile, echo=False).roster  # a restarted profile admits it


@pytest.mark.live
def test_up_refuses_a_router_beyond_loopback_without_security(tmp_path):
    profile = write_profile(tmp_path, f"tcp/0.0.0.0:{free_port()}")
    out = cli("up", str(profile), "--quiet", timeout=30)
    assert out.returncode == 2 and "beyond this machine" in out.stderr and "--insecure" in out.stderr


@pytest.mark.live
def test_up_refuses_to_join_another_machine_in_the_clear(tmp_path):
    profile = write_profile(tmp_path, f"tcp/127.0.0.1:{free_port()}")
    out = cli("up", str(profile), "--join", "tcp/192.0.2.7:7447", "--quiet", timeout=30)
    assert out.returncode == 2 and "link to tcp/192.0.2.7:7447 in the clear" in out.stderr, out.stderr


def test_a_joining_profile_runs_its_own_router_and_links_it_securely(tmp_path):
    joined = load_profile(write_profile(tmp_path, "tls/127.0.0.1:7447", tmp_path / "certs"), join="quic/192.0.2.7:7447",
                          check_security=False)
    assert joined.upstream == "quic/192.0.2.7:7447" and joined.router == "tls/127.0.0.1:7447"
    assert "router.router" in joined.identities()
    with pytest.raises(ProfileError, match=r"--join: with zenoh.security the other machine's router is reached on "
                                           r"tls/.*'tcp/192.0.2.7:7447'"):
        load_profile(write_profile(tmp_path, "tls/127.0.0.1:7447", tmp_path / "certs"), join="tcp/192.0.2.7:7447")


def test_security_settings_are_checked_with_errors_that_name_the_field(tmp_path):
    with pytest.raises(ProfileError, match=r"zenoh.router: a tls/ endpoint needs zenoh.security"):
        load_profile(write_profile(tmp_path, "tls/127.0.0.1:7447"))
    with pytest.raises(ProfileError, match=r"zenoh.router: with zenoh.security the router listens on tls/"):
        load_profile(write_profile(tmp_path, "tcp/127.0.0.1:7447", tmp_path / "certs"))
    (tmp_path / "nothing").mkdir()
    with pytest.raises(ProfileError, match=r"zenoh.security: .* lacks router.router, supervisor.suptest, "
                                           r"recorder.recorder, platform.platform, teacher.teacher, "
                                           r"learner.learner") as err:
        load_profile(write_profile(tmp_path, "tls/127.0.0.1:7447", tmp_path / "nothing"))
    assert "make them with `dogged certs" in str(err.value)
    (tmp_path / "nothing" / "ca.key").write_text("a CA key beside the services' certificates")
    with pytest.raises(ProfileError, match=r"zenoh.security: .* holds ca.key at its top: the CA's key belongs outside"):
        load_profile(write_profile(tmp_path, "tls/127.0.0.1:7447", tmp_path / "nothing"))


@pytest.mark.parametrize("endpoint,local", [("tcp/127.0.0.1:7447", True), ("tls/[::1]:7447", True),
                                            ("tcp/localhost:7447", True), ("tcp/0.0.0.0:7447", False),
                                            ("tls/192.168.1.5:7447", False), ("tcp/robot.lan:7447", False)])
def test_loopback_endpoints(endpoint, local):
    assert is_loopback(endpoint) == local
