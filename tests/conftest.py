import services  # noqa: F401  (first: one BLAS thread per process, see services/__init__.py)
import pytest

from tests.harness import dogged, free_port, stop


@pytest.fixture
def router(tmp_path):
    """A real Zenoh router (a Python process) on a free loopback port; yields its endpoint."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = dogged("run", "router", "--listen", endpoint, log=tmp_path / "router.log")
    yield endpoint
    stop(proc)
