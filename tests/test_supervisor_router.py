"""A supervisor whose router cannot start says so within seconds (issue 30): it blocked for ever on a
port another program held or a mistyped endpoint, and on a port another profile's router held it
silently joined that bus and started its services there."""
import socket
import subprocess
import sys
import time

from tests.harness import REPO, dogged, free_port, stop

PROFILE = """
[profile]
name = "held"
log_dir = "{logs}"
record = false

[services.platform]
box = "platform"
args = ["--platform", "point", "--param", "dims=2"]
"""


def up_until_it_ends(tmp_path, endpoint: str, timeout: float = 30.0) -> tuple[int | None, float, str]:
    """(exit code or None if it still ran after `timeout`, seconds it took, what it printed)."""
    profile = tmp_path / "held.toml"
    profile.write_text(PROFILE.format(logs=tmp_path / "logs"))
    log = tmp_path / "up.log"
    started = time.monotonic()
    sup = dogged("up", str(profile), "--router", endpoint, log=log)
    try:
        code = sup.wait(timeout)
    except subprocess.TimeoutExpired:
        code = None
    finally:
        stop(sup)
    return code, time.monotonic() - started, log.read_text()


def test_a_port_another_program_holds_fails_up_within_seconds(tmp_path):
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        endpoint = f"tcp/127.0.0.1:{held.getsockname()[1]}"
        code, took, said = up_until_it_ends(tmp_path, endpoint)
    assert code == 1 and took < 20.0, f"exit {code} after {took:.0f} s:\n{said[-2000:]}"
    assert f"the router cannot listen on {endpoint}" in said and "Address already in use" in said, said[-2000:]
    assert "[platform]" not in said and "nothing started" in said, said[-2000:]


def test_a_port_another_profiles_router_holds_is_not_joined(tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    other = subprocess.Popen([sys.executable, "-m", "services.cli", "run", "router", "--listen", endpoint], cwd=REPO,
                             stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    try:
        time.sleep(2.0)  # (it listens well within this)
        assert other.poll() is None
        code, took, said = up_until_it_ends(tmp_path, endpoint)
    finally:
        stop(other)
    assert code == 1 and took < 20.0, f"exit {code} after {took:.0f} s:\n{said[-2000:]}"
    assert f"the router cannot listen on {endpoint}" in said, said[-2000:]
    assert "[platform]" not in said, "its services did not start on the other profile's bus"


def test_a_mistyped_endpoint_fails_up_within_seconds(tmp_path):
    code, took, said = up_until_it_ends(tmp_path, "tcp/127.0.0.1:99999")
    assert code == 1 and took < 20.0, f"exit {code} after {took:.0f} s:\n{said[-2000:]}"
    assert "the router cannot listen on tcp/127.0.0.1:99999" in said, said[-2000:]
