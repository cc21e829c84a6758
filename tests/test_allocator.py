"""services/allocator.py: the C allocator's thresholds are fixed at import of services (glibc), unless the
environment sets glibc's own."""
import sys

import pytest

from services import allocator


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="mallopt is glibc's")
def test_the_thresholds_are_set_where_the_environment_leaves_them():
    assert allocator.glibc()  # the machines this runs on (python:3.11 images, Debian)
    assert allocator.fix_thresholds() is True


@pytest.mark.parametrize("variable", ["MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_"])
def test_glibc_own_variables_win(monkeypatch, variable):
    monkeypatch.setenv(variable, "131072")
    assert allocator.fix_thresholds() is False


def test_the_thresholds_keep_a_fit_s_arrays_on_the_heap():
    n = 256  # fit_points: a kernel matrix of the largest fit, and the trim threshold holds a dozen of them
    assert 8 * n * n < allocator.MMAP_THRESHOLD and 12 * 8 * n * n < allocator.TRIM_THRESHOLD
