"""Keep numba's on-disk cache honest across the LWPR kernel files.

numba invalidates a cached function when its own file changes, not when a file it calls
into changes: after an upgrade that touches lwpr_metric.py alone, the cached learn
kernels in lwpr_kernels.py would keep running the old metric code. We stamp the cache
with a hash of every kernel source and drop the cached LWPR entries when it differs.
"""
from __future__ import annotations

import hashlib
from pathlib import Path

_HERE = Path(__file__).resolve().parent
_SOURCES = tuple(sorted(path.name for path in _HERE.glob("lwpr_*.py")))  # every kernel file, a new one too
_STAMP = "lwpr_kernels.sources-sha256"


def sources_digest() -> str:
    digest = hashlib.sha256()
    for name in _SOURCES:
        digest.update((_HERE / name).read_bytes())
    return digest.hexdigest()


def drop_stale_numba_cache(cache_dir: Path | None = None) -> bool:
    """Remove cached LWPR kernels compiled from other sources; True if any were dropped.

    Best effort: a read-only install keeps numba's own (per-file) invalidation."""
    cache_dir = cache_dir or _HERE / "__pycache__"
    stamp = cache_dir / _STAMP
    digest = sources_digest()
    try:
        if stamp.exists() and stamp.read_text() == digest:
            return False
        dropped = False
        for path in cache_dir.glob("lwpr_*.nb[ic]"):
            path.unlink(missing_ok=True)
            dropped = True
        cache_dir.mkdir(exist_ok=True)
        stamp.write_text(digest)
        return dropped
    except OSError:
        return False
