"""The soak's figures from its samples: each process's growth (a line fitted to its resident memory and its
open file descriptors after its first stretch, per hour), the tick's p99 in the first and last quarters of
the day (outside the faults), the pairs lost, the longest stretch missing from the recordings, restarts,
and the student's error alone: after its first lesson and at the end."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MIN_POINTS = 3  # samples after a process's first stretch, to fit its growth


@dataclass
class Growth:
    service: str
    pid: int
    rss_mb_per_hour: float
    fds_per_hour: float | None  # None: too few samples with the bus's usual members
    rss_mb: tuple          # (first, last) after its first stretch
    fds: tuple             # likewise, of the samples the bus had its usual members
    points: int
    fd_points: int         # those samples


def growth(rows, warmup_s: float) -> list[Growth]:
    """Per process (a service's each run: a restart is another pid), its growth after `warmup_s` of being
    seen, from the samples; processes seen too briefly are left out. The fds only over the samples in which the
    bus had as many members as usual: each Zenoh peer holds two sockets for every other peer while it lives (a
    swap's new learner catching up for minutes beside the old one: two more in every process, gone when the
    old one leaves; tests/test_fds_peers.py), which is the membership's size, not a leak."""
    usual = usual_members(rows)
    series: dict[tuple[str, int], list] = {}
    for row in rows:
        for name, p in row.procs.items():
            series.setdefault((name, p.pid), []).append((row.t, p.rss_mb, p.fds, len(row.procs) == usual))
    out = []
    for (name, pid), points in series.items():
        born = points[0][0]
        kept = np.array([p for p in points if p[0] - born >= warmup_s], dtype=float)
        if len(kept) < MIN_POINTS or kept[-1, 0] - kept[0, 0] <= 0:
            continue
        hours = kept[:, 0] / 3600.0
        rss = np.polyfit(hours, kept[:, 1], 1)[0]
        usual_fds = kept[kept[:, 3] > 0]
        fd_slope, fds = None, (None, None)
        if len(usual_fds):
            fds = (int(usual_fds[0, 2]), int(usual_fds[-1, 2]))
        if len(usual_fds) >= MIN_POINTS and usual_fds[-1, 0] > usual_fds[0, 0]:
            fd_slope = round(float(np.polyfit(usual_fds[:, 0] / 3600.0, usual_fds[:, 2], 1)[0]), 2)
        out.append(Growth(name, pid, round(float(rss), 2), fd_slope,
                          (kept[0, 1], kept[-1, 1]), fds, len(kept), len(usual_fds)))
    return out


def usual_members(rows) -> int:
    """How many processes the samples most often saw (one more while a swap's learner catches up)."""
    sizes = [len(row.procs) for row in rows]
    return max(set(sizes), key=sizes.count) if sizes else 0


def outside(times: np.ndarray, windows: list[tuple[float, float]]) -> np.ndarray:
    keep = np.ones(len(times), dtype=bool)
    for start, end in windows:
        keep &= ~((times >= start) & (times <= end))
    return keep


def quarter_p99s(ticks: list, t0: float, length_s: float, faults: list[tuple[float, float]]) -> tuple:
    """The tick's p99 (ms) over the first and the last quarter of the day, the ticks inside a fault's window
    left out."""
    if not ticks:
        return None, None
    at = np.array([a for a, _, _ in ticks])
    ms = np.array([dt for _, dt, _ in ticks]) * 1e3
    keep = outside(at, faults)
    q = length_s / 4

    def p99(lo, hi):
        chosen = keep & (at >= t0 + lo) & (at < t0 + hi)
        return round(float(np.percentile(ms[chosen], 99)), 3) if chosen.any() else None
    return p99(0, q), p99(length_s - q, length_s + 1e9)


def alone_errors(errors: list) -> list[float]:
    """The student's mean error over each span alone, in order (a span with no judged tick is left out)."""
    spans: dict[int, list] = {}
    for _, span, error, _ in errors:
        spans.setdefault(span, []).append(error)
    return [float(np.mean(spans[s])) for s in sorted(spans)]


def last_span_split(errors: list) -> dict:
    """The last span alone told apart: its ticks the learner's answer drove (their mean error: the student's own)
    and the others (held, its answer having missed the deadline; or a default controller's), so that a last error
    above what the teaching makes of the student says whose it is. Counts of 0 and errors of None: no such tick."""
    last = max((span for _, span, _, _ in errors), default=None)
    by_learner: dict[bool, list] = {True: [], False: []}
    for _, span, error, learners in errors:
        if span == last:
            by_learner[learners].append(error)

    def mean(values: list) -> float | None:
        return round(float(np.mean(values)), 4) if values else None
    return {"answered": len(by_learner[True]), "held": len(by_learner[False]),
            "error_answered": mean(by_learner[True]), "error_held": mean(by_learner[False])}
