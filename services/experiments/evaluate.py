"""The paper's quantitative evaluation (section V.B, Figure 5): run the teacher program on every
input the student saw, taught or not, and plot the error between teacher and student over time
with the spans where the teacher was active.

Works on recorded arrays only (a Trace, or the recorder's log of a process run).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np


def teacher_outputs(teacher, inputs: np.ndarray, n_out: int | None = None) -> np.ndarray:
    """The teacher's answer to each input row; rows where it says nothing are NaN (`n_out`
    defaults to the teacher's output space)."""
    n_out = n_out or teacher.spaces.output.dims
    rows = []
    for x in np.asarray(inputs, dtype=np.float64):
        y, _ = teacher(x)
        rows.append(np.full(n_out, np.nan) if y is None else np.asarray(y, dtype=np.float64))
    return np.asarray(rows)


def error_over_time(teacher_y: np.ndarray, student_y: np.ndarray, outputs=None, scale=None) -> np.ndarray:
    """Per tick, the RMS over `outputs` (default all) of (teacher - student) / scale. `scale` (per
    output, e.g. half the range) puts outputs of different units on one footing."""
    diff = np.asarray(teacher_y, dtype=np.float64) - np.asarray(student_y, dtype=np.float64)
    if scale is not None:
        diff = diff / np.asarray(scale, dtype=np.float64)
    if outputs is not None:
        diff = diff[:, list(outputs)]
    return np.sqrt(np.mean(diff ** 2, axis=1))


def figure5_error(teacher, inputs: np.ndarray, student_y: np.ndarray, outputs=None,
                  scale=None) -> tuple[np.ndarray, np.ndarray]:
    """The paper's Figure 5 measure, the one every experiment, the demo and the benchmark use: the
    teacher program run on every input the student saw, and per tick the RMS over `outputs` of
    (teacher - student) / scale. Returns (the teacher's outputs, the error per tick)."""
    teacher_y = teacher_outputs(teacher, inputs)
    return teacher_y, error_over_time(teacher_y, student_y, outputs=outputs, scale=scale)


def half_range(box) -> np.ndarray:
    """Half of each output's range: the scale that puts outputs of different units on one footing."""
    return (np.asarray(box.high, dtype=np.float64) - np.asarray(box.low, dtype=np.float64)) / 2


def asking_rate(modes, chosen=None) -> float | None:
    """Of the ticks the student drove (those `chosen`, default all), the fraction in which it asked
    for teaching (mode 'unsure', green ears); None if it drove none of them."""
    modes = np.asarray(modes)
    driving = modes != "teacher"
    if chosen is not None:
        driving &= np.asarray(chosen, dtype=bool)
    return float(np.mean(modes[driving] == "unsure")) if driving.any() else None


def percent(fraction: float | None) -> str:
    """A fraction as a whole percentage for tables and summaries; n/a for None (nothing to count)."""
    return "n/a" if fraction is None else f"{fraction:.0%}"


def teaching_bands(t: np.ndarray, teaching: np.ndarray) -> list[tuple[float, float]]:
    """(start, stop) times of each run of ticks with the teacher on; stop is the next tick's time."""
    t, teaching = np.asarray(t, dtype=np.float64), np.asarray(teaching, dtype=bool)
    if len(t) == 0:
        return []
    step = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    edges = np.diff(np.concatenate([[0], teaching.astype(int), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(float(t[a]), float(t[b - 1] + step)) for a, b in zip(starts, stops)]


def moving_average(values: np.ndarray, window: int) -> np.ndarray:
    """Trailing mean over `window` ticks (shorter at the start), so a curve is readable at 30 Hz."""
    values = np.asarray(values, dtype=np.float64)
    cumulative = np.concatenate([[0.0], np.cumsum(values)])
    idx = np.arange(1, len(values) + 1)
    lo = np.maximum(idx - window, 0)
    return (cumulative[idx] - cumulative[lo]) / (idx - lo)


def first_band_drop(t: np.ndarray, error: np.ndarray, teaching: np.ndarray, seconds: float = 1.0) -> tuple[float,
                                                                                                           float]:
    """Mean error over the first and over the last `seconds` of the first teaching span: the
    Figure 5 claim 'error goes high and then quickly falls' holds when the second is smaller."""
    bands = teaching_bands(t, teaching)
    if not bands:
        raise ValueError("the teacher was never active, so there is no teaching span to measure")
    start, stop = bands[0]
    t, error = np.asarray(t), np.asarray(error)
    first = error[(t >= start) & (t < min(start + seconds, stop))]
    last = error[(t >= max(stop - seconds, start)) & (t < stop)]
    return float(np.mean(first)), float(np.mean(last))


def plot_error(path: Path, t: np.ndarray, error: np.ndarray, teaching: np.ndarray, title: str,
               ylabel: str = "RMS error", smooth_window: int = 1, phases: dict | None = None,
               asking: np.ndarray | None = None) -> Path:
    """Figure 5: error against time, the teacher's active spans shaded; `phases` (label -> (start,
    stop) seconds) are marked and named along the top; `asking` (per tick: the robot asked to be
    taught) is a green strip along the bottom. Saves a PNG and returns its path."""
    import matplotlib

    matplotlib.use("Agg")  # headless: no display on CI or the benchmark machine
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.2), dpi=110)
    for i, (start, stop) in enumerate(teaching_bands(t, teaching)):
        ax.axvspan(start, stop, color="tab:red", alpha=0.15, lw=0, label="teacher active" if i == 0 else None)
    for i, (start, stop) in enumerate(teaching_bands(t, asking) if asking is not None else []):
        ax.axvspan(start, stop, ymax=0.06, color="tab:green", alpha=0.6, lw=0,
                   label="robot asks (unsure)" if i == 0 else None)
    ax.plot(t, error, color="0.6", lw=0.6, label="error (per tick)")
    if smooth_window > 1:
        ax.plot(t, moving_average(error, smooth_window), color="tab:blue", lw=1.4,
                label=f"mean of {smooth_window} ticks")
    for label, (start, stop) in (phases or {}).items():
        ax.axvline(start, color="0.3", lw=0.7, ls=":")
        ax.text((start + stop) / 2, 1.0, label, transform=ax.get_xaxis_transform(), ha="center", va="bottom",
                fontsize=7)
    ax.set_xlabel("time (s, simulated)")
    ax.set_ylabel(ylabel)
    ax.set_title(title, pad=14 if phases else 6)
    ax.set_xlim(float(t[0]) if len(t) else 0, float(t[-1]) if len(t) else 1)
    ax.set_ylim(bottom=0)
    return save_figure(fig, ax, path)


def save_figure(fig, ax, path: Path) -> Path:
    """A plot's legend and layout, saved as a PNG (its folder made), the figure closed; returns the path."""
    import matplotlib.pyplot as plt

    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path
