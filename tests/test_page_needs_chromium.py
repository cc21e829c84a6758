"""Without chromium (make test as a user) the page's tests are skipped, saying what to install; with it
they run."""
import subprocess
import sys

import pytest

from rigs.harness import REPO
from rigs.headless import missing_chromium


def test_no_chromium_says_which_apt_command_installs_it(tmp_path):
    reason = missing_chromium(tmp_path / "chromium")
    assert reason == (f"no chromium at {tmp_path / 'chromium'}: the page's tests need Debian's chromium: "
                      "`sudo apt-get install chromium` (make test does, as root), or set DOGGED_CHROMIUM to one")


def test_a_chromium_there_is_used(tmp_path):
    (tmp_path / "chromium").touch()
    assert missing_chromium(tmp_path / "chromium") is None


@pytest.mark.live
def test_the_pages_tests_skip_with_that_reason_when_chromium_is_missing(tmp_path):
    env = {"DOGGED_CHROMIUM": str(tmp_path / "absent"), "PATH": "/usr/bin:/bin"}
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider",
                           "tests/test_ui_page.py", "tests/test_ui_teleop.py"],
                          cwd=REPO, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "skipped" in done.stdout and "passed" not in done.stdout and "failed" not in done.stdout
    assert f"no chromium at {tmp_path / 'absent'}" in done.stdout and "sudo apt-get install chromium" in done.stdout
