"""`dogged ui` off loopback, as a real process on a real bus: the page is served over HTTPS with a
certificate made for the run, the printed address carries the token and the certificate's fingerprint,
and a page that presents the token over wss gets the robot's hello. Bad TLS flags stop it at start."""
import asyncio
import re
import subprocess
import sys

from tests.harness import REPO, dogged, free_port, stop, wait_until
from tests.test_ui_protocol import exchange, served_fingerprint, tls_client


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
