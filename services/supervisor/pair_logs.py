"""Whose pair log a profile's learner starts from. A hot-swapped learner (<service>-s<n>) keeps a pair log
of its own: the old one's history and everything taught after. At the next `dogged up` the profile's
learner is <service> again, and read only <service>.pairs, the log of the learner the first swap retired:
everything taught since was forgotten. So before anything starts, the newest log of a service's swaps
becomes its own; every log replaced is kept, renamed, never deleted.
"""
from __future__ import annotations

import logging
import re
import time
from pathlib import Path

log = logging.getLogger("dogged.supervisor")


def set_aside(log_file: Path, why: str) -> Path:
    """Renames a pair log out of the way (<name>.pairs.<time>.earlier) and says so; returns its new path."""
    aside = log_file.with_name(f"{log_file.name}.{time.strftime('%Y%m%d-%H%M%S')}.earlier")
    n = 1
    while aside.exists():  # two set aside within a second
        aside = log_file.with_name(f"{log_file.name}.{time.strftime('%Y%m%d-%H%M%S')}-{n}.earlier")
        n += 1
    log_file.rename(aside)
    log.warning("%s set aside as %s: %s", log_file, aside.name, why)
    return aside


def set_aside_stale_log(state_dir: Path | None, name: str) -> None:
    """A pair log under a swap's new name is an earlier run's (swap numbers start again with each `dogged up`):
    replayed, it would stand in for warming from the learner being replaced."""
    if state_dir is not None and (state_dir / f"{name}.pairs").exists():
        set_aside(state_dir / f"{name}.pairs", "an earlier run's, before the swap")


def adopt_successor_log(state_dir: Path | None, service: str) -> str | None:
    """Before `service` starts: the log of whichever of its swaps wrote last, if newer than its own, becomes
    <service>.pairs (its own set aside first); the older swaps' logs are set aside. Returns the adopted log's
    old name, or None."""
    if state_dir is None or not state_dir.is_dir():
        return None
    pattern = re.compile(rf"{re.escape(service)}-s(\d+)\.pairs")
    successors = [(f.stat().st_mtime_ns, int(m.group(1)), f) for f in state_dir.iterdir()
                  if (m := pattern.fullmatch(f.name)) and f.is_file()]
    if not successors:
        return None
    successors.sort()
    newest = successors[-1]
    own = state_dir / f"{service}.pairs"
    for _, _, older in successors[:-1]:
        set_aside(older, f"an older swap's log than {newest[2].name}")
    if own.exists() and own.stat().st_mtime_ns > newest[0]:
        set_aside(newest[2], f"{own.name} was written after it")
        return None
    if own.exists():
        set_aside(own, f"{newest[2].name}, its last swap's, was written after it")
    newest[2].rename(own)
    log.info("%s: %s (the learner that served last) is its pair log now", service, newest[2].name)
    return newest[2].name
