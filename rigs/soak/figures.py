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
    fds_per_hour: float
    rss_mb: tuple          # (first, last) after its first stretch
    fds: tuple
    points: int


def growth(rows, warmup_s: float) -> list[Growth]:
    """Per process (a service's each run: a restart is another pid), its growth after `warmup_s` of being
    seen, from the samples; processes seen too briefly are left out."""
    series: dict[tuple[str, int], list] = {}
    for row in rows:
        for name, p in row.procs.items():
            series.setdefault((name, p.pid), []).append((row.t, p.rss_mb, p.fds))
    out = []
    for (name, pid), points in series.items():
        born = points[0][0]
        kept = np.array([p for p in points if p[0] - born >= warmup_s])
        if len(kept) < MIN_POINTS or kept[-1, 0] - kept[0, 0] <= 0:
            continue
        hours = kept[:, 0] / 3600.0
        rss, fds = np.polyfit(hours, kept[:, 1], 1)[0], np.polyfit(hours, kept[:, 2], 1)[0]
        out.append(Growth(name, pid, round(float(rss), 2), round(float(fds), 2),
                          (kept[0, 1], kept[-1, 1]), (int(kept[0, 2]), int(kept[-1, 2])), len(kept)))
    return out


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
    for _, span, error in errors:
        spans.setdefault(span, []).append(error)
    return [float(np.mean(spans[s])) for s in sorted(spans)]
