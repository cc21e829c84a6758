"""`dogged ui` off loopback, as a real process on a real bus: the page is served over HTTPS with a
certificate made for the run, the printed address carries the token and the certificate's fingerprint,
and a page that presents the token over wss gets the robot's hello. Bad TLS flags stop it at start."""
import asyncio
import re
import subprocess
import sys

import pytest

from rigs.harness import REPO, dogged, free_port, stop, wait_until
from tests.test_ui_protocol import exchange, served_fingerprint, tls_client

pytestmark = pytest.mark.live


def test_off_loopback_the_page_is_served_over_https_with_the_printed_token_and_fingerprint(router, tmp_path):
    port = free_port()
    c = ["--connect", router]
    platform = dogged("run", "platform", "--param", "dims=2", "--rate", "10", *c, log=tmp_path / "platform.log")
    ui = dogged("ui", "--http", f"0.0.0.0:{port}", "--robot", "none", *c, log=tmp_path / "ui.log")
    try:
        line = wait_until(lambda: re.search(r"dogged ui: open https://\S+:(\d+)/\?token=(\S+); certificate SHA-256 "
                                            r"([0-9A-F:]{95})", (tmp_path / "ui.log").read_text()), 60,
                          "the printed address")
        served, token, printed = int(line[1]), line[2], line[3]
        assert served_fingerprint(served) == printed
        hello, _ = asyncio.run(exchange(f"wss://127.0.0.1:{served}/ws?token={token}", [], ssl=tls_client()))
        assert hello["instance"] == "main" and hello["outputs"]["names"]
    finally:
        assert stop(ui, platform) == [0, 0]


def test_tls_flags_that_cannot_work_stop_dogged_ui_at_start_naming_the_flag(tmp_path):
    (tmp_path / "k.pem").write_text("no key")
    for args, named in [(["--tls-cert", str(tmp_path / "none.pem"), "--tls-key", str(tmp_path / "k.pem")],
                         "--tls-cert"),
                        (["--tls-cert", str(tmp_path / "k.pem")], "--tls-key is needed too"),
                        (["--plain-http", "--tls-key", str(tmp_path / "k.pem")], "contradict")]:
        done = subprocess.run([sys.executable, "-m", "services.cli", "ui", *args], cwd=REPO, capture_output=True,
                              text=True, timeout=60)
        assert done.returncode == 2 and named in done.stderr, done.stderr[-500:]


def test_the_bridge_declares_on_the_main_thread_so_exit_waits_for_its_callback_threads(router):
    """zenoh-python runs each Python callback on a thread that inherits the declaring thread's daemon
    flag. The ui's bridge used to declare on its daemon bus thread: at exit those threads were not
    waited for and woke into a finalizing interpreter as the session closed, aborting the process
    (-6, 'FATAL: exception not rethrown': 7 of 100 exits in a script here, 0 of 100 declared on main)."""
    import logging
    import threading

    import zenoh

    from bus_schema import Box, InstanceKeys, Spaces
    from services.bus.config import zenoh_config
    from services.bus.runtime import BoxRuntime
    from services.ui.bridge import Bridge
    from tests.fakebus import FakeStop

    def callback_threads():
        return [t for t in threading.enumerate() if t is not threading.main_thread() and "pyo3" in t.name]
    spaces = Spaces(Box.uniform(2, -1.0, 1.0), Box.uniform(2, -1.0, 1.0))
    with zenoh.open(zenoh_config(connect=[router], mode="client")) as session:
        before = set(callback_threads())
        box = BoxRuntime(session, InstanceKeys("main"), "ui", "ui", stop=FakeStop(0), log=logging.getLogger("test"))
        with box:
            bridge = Bridge(box, "none", "person", spaces, lambda *_: None)
            refused = []
            daemon = threading.Thread(target=lambda: refused.append(pytest.raises(RuntimeError, bridge.declare)),
                                      daemon=True)
            daemon.start()
            daemon.join(10)
            assert refused and "daemon" in str(refused[0].value) and not set(callback_threads()) - before
            bridge.declare()  # as `dogged ui` does, on its main thread
            made = [t for t in callback_threads() if t not in before]
            assert made and not any(t.daemon for t in made)
            bridge.run()  # stopped: ends at once
        # the runtime ended, its declarations with it: the callback threads end with the interpreter alive
        wait_until(lambda: not any(t.is_alive() for t in made), 10, "the callback threads ended")
