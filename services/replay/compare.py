"""Learners compared on one recorded run: each one's error against the teacher over time, the figures a
person compares them by, a table and a plot."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from services.experiments.evaluate import (error_over_time, half_range, moving_average, save_figure, teacher_outputs,
                                          teaching_bands)
from services.recording.runs import RecordedRun
from services.replay.replay import Replayed

SMOOTH_S = 1.0  # the error curve's trailing mean (and teaching it takes before "reached" can count)


@dataclass
class Figures:
    spec: str
    final_error: float          # mean over the last tenth of the inputs with a reference
    student_error: float        # mean over the ticks the student drove (NaN: no reference there)
    reach_s: float              # first time, SMOOTH_S after teaching began, the trailing mean fell under the
                                # threshold (NaN: never); before, an untaught model may be right by chance
    updates_per_s: float
    size: int
    wrong_confidence: float     # mean confidence where the error exceeded the threshold (NaN: never wrong)
    error: np.ndarray           # per input, NaN where no reference

    def row(self) -> dict:
        return {k: (None if isinstance(v, float) and np.isnan(v) else v) for k, v in vars(self).items()
                if k != "error"}


def reference(run: RecordedRun, teacher=None) -> np.ndarray:
    """The teacher's output at each input: the named teacher program run on every input, else its recorded
    outputs where it spoke (NaN elsewhere)."""
    if teacher is None:
        return run.taught_at_ticks()
    return teacher_outputs(teacher, run.x, run.spaces.output.dims)


def smoothing_window(run: RecordedRun) -> int:
    """Inputs in SMOOTH_S seconds of the run."""
    return max(1, int(round(SMOOTH_S / max(np.median(np.diff(run.t)), 1e-6)))) if len(run.t) > 1 else 1


def figures(run: RecordedRun, result: Replayed, ref: np.ndarray, threshold: float) -> Figures:
    error = error_over_time(np.nan_to_num(ref), result.y, scale=half_range(run.spaces.output))
    error[~np.isfinite(ref).all(axis=1)] = np.nan  # where the teacher said nothing, or not all of it
    known = np.flatnonzero(np.isfinite(error))
    final = float(np.mean(error[known[-max(1, len(known) // 10):]])) if len(known) else np.nan
    student = (run.modes != "teacher") & (run.modes != "") & np.isfinite(error)
    smooth = moving_average(error[known], smoothing_window(run)) if len(known) else np.array([])
    taught = np.flatnonzero(run.modes == "teacher")
    begins = (run.t[taught[0]] if len(taught) else run.t[0]) + SMOOTH_S if len(run.t) else 0.0
    under = np.flatnonzero((smooth < threshold) & (run.t[known] >= begins))
    wrong = np.isfinite(error) & (error > threshold)
    return Figures(result.spec, final, float(np.mean(error[student])) if student.any() else np.nan,
                   float(run.t[known[under[0]]]) if len(under) else np.nan,
                   result.updates / result.learn_s if result.learn_s > 0 else np.nan, result.size,
                   float(np.mean(result.confidence[wrong])) if wrong.any() else np.nan, error)


def table(rows: list[Figures], threshold: float) -> str:
    def fmt(v, spec):
        return "n/a" if v is None or (isinstance(v, float) and np.isnan(v)) else format(v, spec)
    head = (f"{'learner':<24}{'final err':>10}{'student err':>12}{f'reach <{threshold:g}':>12}{'updates/s':>11}"
            f"{'size':>7}{'conf wrong':>11}")
    lines = [head, "-" * len(head)]
    for f in rows:
        lines.append(f"{f.spec[:23]:<24}{fmt(f.final_error, '.4f'):>10}{fmt(f.student_error, '.4f'):>12}"
                     f"{fmt(f.reach_s, '.1f') + (' s' if not np.isnan(f.reach_s) else ''):>12}"
                     f"{fmt(f.updates_per_s, ',.0f'):>11}{f.size:>7}{fmt(f.wrong_confidence, '.2f'):>11}")
    return "\n".join(lines)


def plot(path: Path, run: RecordedRun, rows: list[Figures], title: str) -> Path:
    """Error over time per learner (trailing mean), the spans where the teacher drove shaded."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.4), dpi=110)
    for i, (start, stop) in enumerate(teaching_bands(run.t, run.modes == "teacher")):
        ax.axvspan(start, stop, color="tab:red", alpha=0.12, lw=0, label="teacher drove" if i == 0 else None)
    window = smoothing_window(run)
    for f in rows:
        known = np.isfinite(f.error)
        if known.any():
            ax.plot(run.t[known], moving_average(f.error[known], window), lw=1.3, label=f.spec)
    ax.set_xlabel("time (s, recorded)")
    ax.set_ylabel(f"error vs teacher (mean of {SMOOTH_S:g} s)")
    ax.set_title(title)
    ax.set_ylim(bottom=0)
    return save_figure(fig, ax, path)
