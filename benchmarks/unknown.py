"""Learning tasks nobody tuned for: every learner taught random nonlinear maps on robot-like streams.

    .venv/bin/python benchmarks/unknown.py [--tasks 20] [--first-task 0] [--quick]

Each task (services.learners.unknown_tasks, seeded by its number): 18 inputs with the Aibo's joint
ranges -> 18 outputs, 2-4 relevant inputs, 1-3 outputs taught by a partial teacher, smooth nonlinear
targets of bounded slope spanning 1.3 rad; every input moves along a smooth trajectory at 30 Hz, the
distractors too (some dragged along by a relevant input). Each learner (per-output over it, as the
mirroring profile wires its learner) is taught for 10, 30 and 60 s and after each answers the next
30 s alone. Then the wired learner on i.i.d. inputs and on a small shape (4 -> 2, unit ranges).
Prints a table per case; the last line is one JSON object (headline keys: the wired learner's).
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: rigs.*, benchmarks.*
import services  # noqa: E402,F401  (first: one BLAS thread per process, see services/__init__.py)

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from services.experiments.unknown import judge, pooled  # noqa: E402
from services.experiments.wiring import wired_learner  # noqa: E402
from services.learners import LEARNERS  # noqa: E402
from services.learners.unknown_tasks import draw_task  # noqa: E402
from services.platforms.aibo.joints import JOINT_LIMITS  # noqa: E402

CHECKPOINTS = (10.0, 30.0, 60.0)
JOINTS = (JOINT_LIMITS[:, 0], JOINT_LIMITS[:, 1], JOINT_LIMITS[:, 0], JOINT_LIMITS[:, 1])
SMALL = (-np.ones(4), np.ones(4), -np.ones(2), np.ones(2))
TARGETS = "targets: RMS < 0.05 median / < 0.1 worst after 30 s; nothing beyond the taught range + 10 %; no NaN; " \
          "confident RMS < 0.05; asks on >= 80 % of ticks wrong by > 0.2"


def run_case(learner: str, params: dict, tasks: list[int], boxes, kind: str, label: str) -> dict:
    per_task, started = [], time.perf_counter()
    for number in tqdm(tasks, desc=label, file=sys.stderr, leave=False):
        task = draw_task(number, *boxes)
        per_task.append(judge(task, learner, params, CHECKPOINTS, kind=kind, seed=number))
    figures = {"seconds_per_task": round((time.perf_counter() - started) / len(tasks), 2)}
    for i, seconds in enumerate(CHECKPOINTS):
        rms = [checkpoints[i].rms for checkpoints in per_task]
        figures[f"rms_{seconds:.0f}s_median"], figures[f"rms_{seconds:.0f}s_worst"] = float(np.median(rms)), max(rms)
    figures.update(pooled([c for checkpoints in per_task for c in checkpoints]))
    figures["rms_30s_per_task"] = [round(checkpoints[1].rms, 4) for checkpoints in per_task]
    return figures


def fmt(value, digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def table(title: str, rows: dict) -> str:
    head = (f"{'learner':<12}{'RMS 10 s':>14}{'RMS 30 s':>14}{'RMS 60 s':>14}{'max |err|':>10}{'beyond':>8}"
            f"{'NaN':>7}{'sure RMS':>9}{'sure':>6}{'asks|wrong':>11}{'s/task':>7}")
    lines = [title,
             "  (RMS: median / worst task, rad; beyond: past the taught range + 10 % of its span, rad, <= 0 never;"
             " sure: share of answers with confidence > 0.75)", head, "-" * len(head)]
    for name, f in rows.items():
        lines.append(f"{name:<12}" + "".join(f"{fmt(f[f'rms_{s:.0f}s_median']):>7}/{fmt(f[f'rms_{s:.0f}s_worst']):<6}"
                                             for s in CHECKPOINTS)
                     + f"{fmt(f['max_abs_err'], 2):>10}{fmt(f['beyond_taught'], 2):>8}{fmt(f['nan_share'], 4):>7}"
                     + f"{fmt(f['confident_rms']):>9}{f['confident_share']:>6.0%}"
                     + f"{'-' if f['asks_when_wrong'] is None else format(f['asks_when_wrong'], '.0%'):>11}"
                     + f"{f['seconds_per_task']:>7.1f}")
    return "\n".join(lines)


def main(n_tasks: int, first: int, quick: bool) -> dict:
    tasks = list(range(first, first + n_tasks))
    wired, wired_params = wired_learner("mirroring")
    base = wired_params.get("base", wired) if wired == "per-output" else wired
    base_params = wired_params.get("params", {}) if wired == "per-output" else wired_params
    names = [base] + sorted(name for name in LEARNERS if name not in (base, "per-output"))
    main_rows = {name: run_case(name, base_params if name == base else {}, tasks, JOINTS, "trajectory",
                                f"{name}, trajectories") for name in names}
    others = tasks[:3] if quick else tasks
    extra = {"iid": run_case(base, base_params, others, JOINTS, "iid", f"{base}, i.i.d."),
             "small": run_case(base, base_params, others, SMALL, "trajectory", f"{base}, 4 -> 2")}
    print(table(f"{n_tasks} random tasks {tasks[0]}..{tasks[-1]}, 18 -> 18, trajectories at 30 Hz "
                f"(wired: per-output {base})", main_rows))
    print()
    print(table(f"the wired learner on {len(others)} tasks: i.i.d. inputs (18 -> 18); a small shape (4 -> 2, "
                "trajectories)", {f"{base} iid": extra["iid"], f"{base} 4->2": extra["small"]}))
    print(TARGETS)
    w = main_rows[base]
    return {"tasks": n_tasks, "first_task": first, "learner": f"per-output {base}",
            "unknown_rms_30s_median": round(w["rms_30s_median"], 4), "unknown_rms_30s_worst": round(w["rms_30s_worst"],
                                                                                                    4),
            "unknown_max_abs_err": round(w["max_abs_err"], 4), "unknown_nan_share": w["nan_share"],
            "confident_rms": None if w["confident_rms"] is None else round(w["confident_rms"], 4),
            "asks_when_wrong": None if w["asks_when_wrong"] is None else round(w["asks_when_wrong"], 3),
            "beyond_taught": round(w["beyond_taught"], 4),
            "learners": {name: {k: (round(v, 4) if isinstance(v, float) else v) for k, v in f.items()}
                         for name, f in main_rows.items()},
            "iid": extra["iid"], "small": extra["small"]}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tasks", type=int, default=20, help="random tasks (default 20)")
    parser.add_argument("--first-task", type=int, default=0, help="number of the first task (default 0)")
    parser.add_argument("--quick", action="store_true", help="5 tasks, a minute or two")
    args = parser.parse_args()
    print(json.dumps(main(5 if args.quick else args.tasks, args.first_task, args.quick), default=float))
