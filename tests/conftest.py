import services  # noqa: F401  (first: one BLAS thread per process, see services/__init__.py)
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from rigs.harness import REPO, dogged, free_port, stop
from services.own_identities import HOME_ENV
from tests.fast_tier import pytest_addoption, pytest_collection_modifyitems, pytest_configure  # noqa: F401  (hooks)

COMPILE_EVERY_LEARNER = ("import services; from services.learners import LEARNERS, compile_kernels, make_learner; "
                         "[compile_kernels(make_learner(name, 2, 1)) for name in LEARNERS]; "
                         "import matplotlib.font_manager")  # its font cache: built cold, it runs fc-list


def pytest_sessionstart(session):
    """This user's own identities (what a profile without zenoh.security runs with) in a folder of the
    session's, never the person's own; and every learner's kernels compiled into numba's cache once, in
    one process, before any test: processes that each compile them cold can round differently (a replay
    then differed from the live learner by up to 3e-9), while processes that load the same cache agree
    bit for bit. The same process builds matplotlib's font cache, which it makes with fc-list (a process,
    which the fast tier refuses) the first time a figure is drawn on a machine."""
    own = Path(tempfile.mkdtemp(prefix="dogged-home-"))  # 0700, made by mkdtemp
    os.environ[HOME_ENV] = str(own)
    subprocess.run([sys.executable, "-c", COMPILE_EVERY_LEARNER], cwd=REPO, check=True, capture_output=True)


@pytest.fixture
def router(tmp_path):
    """A real Zenoh router (a Python process) on a free loopback port; yields its endpoint."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = dogged("run", "router", "--listen", endpoint, log=tmp_path / "router.log")
    yield endpoint
    stop(proc)
