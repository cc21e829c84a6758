"""A supervisor whose router cannot start says so within seconds (issue 30): it blocked for ever on a
port another program held or a mistyped endpoint, and on a port another profile's router held it
silently joined that bus and started its services there."""
import json
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rigs.harness import REPO, Probe, dogged, dogged_ok, free_port, stop, wait_until
from services.own_identities import secured_endpoint

pytestmark = pytest.mark.live

PROFILE = """
[profile]
name = "{name}"
log_dir = "{logs}"
record = false

[services.{service}]
box = "platform"
args = ["--platform", "point", "--param", "dims=2"]
"""


def profile_file(tmp_path, name: str = "held", service: str = "platform", router: str | None = None) -> Path:
    """A profile of one platform service; `router`: its zenoh.router (else `dogged up --router` says)."""
    text = PROFILE.format(name=name, logs=tmp_path / name, service=service)
    path = tmp_path / f"{name}.toml"
    path.write_text(text + (f'\n[zenoh]\nrouter = "{router}"\n' if router else ""))
    return path


def up_until_it_ends(profile: Path, log: Path, *args: str, timeout: float = 30.0) -> tuple[int | None, float, str]:
    """(exit code or None if it still ran after `timeout`, seconds it took, what it printed)."""
    started = time.monotonic()
    sup = dogged("up", str(profile), *args, log=log)
    try:
        code = sup.wait(timeout)
    except subprocess.TimeoutExpired:
        code = None
    finally:
        stop(sup)
    return code, time.monotonic() - started, log.read_text()


def held_up(tmp_path, endpoint: str) -> tuple[int | None, float, str]:
    return up_until_it_ends(profile_file(tmp_path), tmp_path / "up.log", "--router", endpoint)


def ps(endpoint: str) -> dict:
    result = dogged_ok("ps", "--json", endpoint=endpoint)
    return json.loads(result.stdout) if result.returncode == 0 else {}


def test_a_port_another_program_holds_fails_up_within_seconds(tmp_path):
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        endpoint = f"tcp/127.0.0.1:{held.getsockname()[1]}"
        code, took, said = held_up(tmp_path, endpoint)
    assert code == 1 and took < 20.0, f"exit {code} after {took:.0f} s:\n{said[-2000:]}"
    assert f"the router cannot listen on {secured_endpoint(endpoint)}" in said, said[-2000:]
    assert "Address already in use" in said, said[-2000:]
    assert "[platform]" not in said and "nothing started" in said, said[-2000:]


def test_a_port_another_profiles_router_holds_is_not_joined(tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    other = subprocess.Popen([sys.executable, "-m", "services.cli", "run", "router", "--listen", endpoint], cwd=REPO,
                             stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    try:
        time.sleep(2.0)  # (it listens well within this)
        assert other.poll() is None
        code, took, said = held_up(tmp_path, endpoint)
    finally:
        stop(other)
    assert code == 1 and took < 20.0, f"exit {code} after {took:.0f} s:\n{said[-2000:]}"
    assert f"the router cannot listen on {secured_endpoint(endpoint)}" in said, said[-2000:]
    assert "[platform]" not in said, "its services did not start on the other profile's bus"


def test_a_mistyped_endpoint_fails_up_within_seconds(tmp_path):
    code, took, said = held_up(tmp_path, "tcp/127.0.0.1:99999")
    assert code == 1 and took < 20.0, f"exit {code} after {took:.0f} s:\n{said[-2000:]}"
    assert "the router cannot listen on tls/127.0.0.1:99999" in said, said[-2000:]


def test_a_second_profile_on_the_first_profiles_endpoint_refuses_and_never_joins_its_bus(tmp_path):
    """Two `dogged up`, the second profile's zenoh.router the first's: the second names the endpoint and
    exits; its service never speaks on the first profile's bus, and the first runs on."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    first = dogged("up", str(profile_file(tmp_path, "first", router=endpoint)), log=tmp_path / "first.log")
    probe = None
    try:
        wait_until(lambda: {r["name"]: r["state"] for r in ps(endpoint).get("services", [])}
                   == {"router": "ready", "platform": "ready"}, 60, "the first profile ready")
        probe = Probe(endpoint)
        second = profile_file(tmp_path, "second", service="intruder", router=endpoint)
        code, took, said = up_until_it_ends(second, tmp_path / "second.log")
        probe.wait_for_fresh_status("platform/platform")  # the probe hears the first profile's bus
        assert "platform/intruder" not in probe.status, f"the second profile joined the first's bus:\n{said[-2000:]}"
        assert code == 1 and took < 20.0, f"exit {code} after {took:.0f} s:\n{said[-2000:]}"
        assert f"the router cannot listen on {secured_endpoint(endpoint)}" in said, said[-2000:]
        assert "Address already in use" in said, said[-2000:]
        assert "nothing started" in said and "[intruder]" not in said, said[-2000:]
        after = ps(endpoint)
        assert after["profile"] == "first" and [r["name"] for r in after["services"]] == ["router", "platform"]
        assert first.poll() is None, "the first profile runs on"
    finally:
        if probe:
            probe.close()
        dogged_ok("down", endpoint=endpoint)
        try:
            first_exit = first.wait(30)
        finally:
            stop(first)  # (only if it did not stop: a SIGTERM as it exits would turn its 0 into -15)
    assert first_exit == 0, "the first profile stopped cleanly on `dogged down`"
