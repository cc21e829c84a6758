"""Ball seeking over a learned gait: two levels of Dogged Learning against one, and the teachers.

    .venv/bin/python benchmarks/hierarchy.py [--seeds 10] [--episodes 10] [--quick]

Per seed, in one process (services/experiments/hierarchy.py; deploy/hierarchy.toml's learners):
- chained: the walk level (12 leg targets from movement and gait phase, 60 Hz) and the seek level
  (movement from colour blobs, 15 Hz) taught at once for 90 s by their hand-coded teachers while the
  pink ball is put down in fresh arenas; then both teachers off, `--episodes` of 20 s with the ball;
- flat: the seek level alone taught the same way over the hand-coded gait (the paper's robot);
- teacher: both hand-coded teachers drive the chained robot in the same episodes.
The walk level's joint RMS is its answer against the trot's on 2000 random movements and phases.
Prints a table; the last line is one JSON object with chained_success, flat_success,
teacher_success, walk_teach_s, walk_joint_rms_rad. Target: chained_success >= 0.9 teacher_success.
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository
import services  # noqa: E402,F401  (first: one BLAS thread per process, see services/__init__.py)

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from services.experiments.hierarchy import run_two_levels  # noqa: E402

CASES = {"chained": dict(chained=True, students=True), "flat": dict(chained=False, students=True),
         "teacher": dict(chained=True, students=False)}


def main(seeds: int, episodes: int) -> dict:
    rows, started = [], time.perf_counter()
    print(f"{'seed':>4}  {'chained':>8}{'flat':>8}{'teacher':>9}{'walk taught s':>15}{'walk RMS rad':>14}"
          f"{'walk student':>14}{'s':>6}", flush=True)
    for seed in range(seeds):
        t0 = time.perf_counter()
        results = {name: run_two_levels(seed, n_episodes=episodes, **kw) for name, kw in CASES.items()}
        chained = results["chained"]
        share = chained.walk_modes.get("student", 0) / max(1, sum(chained.walk_modes.values()))
        rows.append({name: r.success for name, r in results.items()}
                    | {"walk_teach_s": chained.walk_teach_s, "walk_joint_rms_rad": chained.walk_joint_rms_rad,
                       "walk_student_share": share})
        print(f"{seed:>4}  {rows[-1]['chained']:>8.0%}{rows[-1]['flat']:>8.0%}{rows[-1]['teacher']:>9.0%}"
              f"{chained.walk_teach_s:>15.1f}{chained.walk_joint_rms_rad:>14.4f}{share:>14.0%}"
              f"{time.perf_counter() - t0:>6.0f}", flush=True)
    mean = {key: float(np.mean([row[key] for row in rows])) for key in rows[0]}
    print("-" * 74)
    print(f"{'mean':>4}  {mean['chained']:>8.0%}{mean['flat']:>8.0%}{mean['teacher']:>9.0%}"
          f"{mean['walk_teach_s']:>15.1f}{mean['walk_joint_rms_rad']:>14.4f}{mean['walk_student_share']:>14.0%}")
    ratio = mean["chained"] / mean["teacher"] if mean["teacher"] else float("nan")
    print(f"chained / teacher success: {ratio:.2f} (target >= 0.9); {seeds} seeds x {episodes} episodes of 20 s; "
          f"{time.perf_counter() - started:.0f} s")
    return {"chained_success": round(mean["chained"], 4), "flat_success": round(mean["flat"], 4),
            "teacher_success": round(mean["teacher"], 4), "walk_teach_s": round(mean["walk_teach_s"], 2),
            "walk_joint_rms_rad": round(mean["walk_joint_rms_rad"], 5),
            "chained_over_teacher": round(ratio, 4), "seeds": seeds, "episodes": episodes}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--quick", action="store_true", help="1 seed, 5 episodes (about a minute and a half)")
    a = parser.parse_args()
    if a.seeds < 1 or a.episodes < 1:
        parser.error("--seeds and --episodes must be at least 1")
    print(json.dumps(main(1, 5) if a.quick else main(a.seeds, a.episodes)))
