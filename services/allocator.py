"""The C allocator's thresholds, fixed at sizes a GP's fits need (glibc only; elsewhere nothing changes).

A fit allocates a dozen n x n arrays an evaluation (half a megabyte each at n = 256, thousands of evaluations a
lesson). glibc serves blocks over 128 KB with mmap and hands the heap's top back to the system past 128 KB free,
raising both thresholds only as larger blocks come and go; until then every such array is fresh pages, each
faulted in. Measured on a recorded mirroring lesson (docs/learners.md): its first replay in a process took 4.86 s
and a second 3.68, and 3.77 / 3.72 with the thresholds fixed here. glibc's own variables (MALLOC_MMAP_THRESHOLD_,
MALLOC_TRIM_THRESHOLD_) win where set.
"""
from __future__ import annotations

import ctypes
import os

M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # glibc's malloc.h
MMAP_THRESHOLD = 4 << 20  # blocks under 4 MB from the heap (an 800-sample GP's factor, 5 MB, is mapped)
TRIM_THRESHOLD = 32 << 20  # up to 32 MB free at the heap's top kept for the next evaluation


def fix_thresholds() -> bool:
    """Set both thresholds in this process unless the environment sets either; True if set."""
    if "MALLOC_MMAP_THRESHOLD_" in os.environ or "MALLOC_TRIM_THRESHOLD_" in os.environ:
        return False
    libc = ctypes.CDLL(None)  # this process's own symbols, libc's among them (find_library would run ldconfig)
    if not hasattr(libc, "mallopt") or not glibc():
        return False
    return bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(libc.mallopt(M_TRIM_THRESHOLD,
                                                                                          TRIM_THRESHOLD))


def glibc() -> bool:
    try:
        return os.confstr("CS_GNU_LIBC_VERSION") is not None
    except (ValueError, OSError, AttributeError):  # no such name here: not glibc
        return False
