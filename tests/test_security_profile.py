"""A profile turns security on with one setting (issue 12): `dogged certs` makes its identities,
`dogged up` runs it over mutual TLS with access control, an operator's certificate steers it and a
teacher's cannot, a person at its page (the ui's operator certificate) switches teaching and drives;
and `dogged up` will not open a router beyond loopback without it."""
import asyncio
import json
import os
import subprocess
import sys

import pytest
from websockets.asyncio.client import connect

from services.security import is_loopback
from services.supervisor.profile import ProfileError, load_profile
from tests.harness import REPO, dogged, free_port, wait_until
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


def write_profile(tmp_path, router, certs=None, page_port=None):
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
    async with connect(f"ws://127.0.0.1:{port}/ws") as ws:

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


def test_a_secured_profile_runs_and_only_an_operator_steers_it(tmp_path):
    certs, endpoint, page_port = tmp_path / "certs", f"tls/127.0.0.1:{free_port()}", free_port()
    profile = write_profile(tmp_path, endpoint, certs, page_port)
    made = cli("certs", str(certs), "--profile", str(profile), "--identity", "operator.bob")
    assert made.returncode == 0, made.stderr
    assert "9 certificates" in made.stdout and (certs / "operator.ui.pem").is_file()
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
        stranger = cli("--connect", endpoint, "ps", timeout=30)
        assert stranger.returncode == 1 and "cannot reach the router" in stranger.stderr
        assert "DOGGED_SECURITY" in stranger.stderr
    finally:
        down = cli("--connect", endpoint, "down", identity="operator.bob", certs=certs)
        code = sup.wait(60)
    assert down.returncode == 0, down.stderr
    assert code == 0


def test_up_refuses_a_router_beyond_loopback_without_security(tmp_path):
    profile = write_profile(tmp_path, f"tcp/0.0.0.0:{free_port()}")
    out = cli("up", str(profile), "--quiet", timeout=30)
    assert out.returncode == 2 and "beyond this machine" in out.stderr and "--insecure" in out.stderr


def test_up_refuses_to_join_another_machine_in_the_clear(tmp_path):
    profile = write_profile(tmp_path, f"tcp/127.0.0.1:{free_port()}")
    out = cli("up", str(profile), "--join", "tcp/192.0.2.7:7447", "--quiet", timeout=30)
    assert out.returncode == 2 and "link to tcp/192.0.2.7:7447 in the clear" in out.stderr, out.stderr


def test_a_joining_profile_runs_its_own_router_and_links_it_securely(tmp_path):
    joined = load_profile(write_profile(tmp_path, "tls/127.0.0.1:7447"), join="quic/192.0.2.7:7447",
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
    with pytest.raises(ProfileError, match=r"zenoh.security: .* lacks router.router, supervisor.suptest, "
                                           r"recorder.recorder, platform.platform, teacher.teacher, "
                                           r"learner.learner") as err:
        load_profile(write_profile(tmp_path, "tls/127.0.0.1:7447", tmp_path / "nothing"))
    assert "make them with `dogged certs" in str(err.value)


@pytest.mark.parametrize("endpoint,local", [("tcp/127.0.0.1:7447", True), ("tls/[::1]:7447", True),
                                            ("tcp/localhost:7447", True), ("tcp/0.0.0.0:7447", False),
                                            ("tls/192.168.1.5:7447", False), ("tcp/robot.lan:7447", False)])
def test_loopback_endpoints(endpoint, local):
    assert is_loopback(endpoint) == local
