"""The paper's experiments, measured: mirroring (one teacher; two teachers in turn), ball seeking,
and the orange ball, over several seeds, single process, simulated time as fast as it goes.

    .venv/bin/python benchmarks/experiments.py [--seeds 10] [--quick] [--out DIR]

Prints a table (median and worst over seeds beside the paper's claim and the target), writes the
Figure 5 PNGs and every run's trace under --out, and ends with one JSON line of the figures.
"""
from __future__ import annotations

import sys
from pathlib import Path

# replace (not prepend) the script's folder, before any import: benchmarks/platform.py would
# otherwise shadow the standard library's `platform`, which numba and tqdm import
sys.path[0] = str(Path(__file__).resolve().parents[1])

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from services.experiments import ballseek, mirroring  # noqa: E402
from services.experiments.ballseek_protocol import run_ballseek, teacher_success  # noqa: E402
from services.experiments.evaluate import first_band_drop, plot_error  # noqa: E402
from services.platforms.aibo.platform import JOINTS_BOX, MOVE_BOX  # noqa: E402
from bus_schema.spaces import Spaces  # noqa: E402

FULL = {"max_teach": 12.0, "seconds_each": 10.0, "episodes": 20, "orange": 5}
QUICK = {"max_teach": 6.0, "seconds_each": 6.0, "episodes": 5, "orange": 2}


def figure5(out: Path, name: str, trace, error, title: str, window: int) -> dict:
    """Save the PNG and the trace; return whether the error fell during the first teaching span."""
    arrays = trace.arrays()
    np.savez_compressed(out / f"{name}.npz", error=error, **arrays)
    plot_error(out / f"{name}.png", arrays["t"], error, arrays["teaching"], title, smooth_window=window)
    start, end = first_band_drop(arrays["t"], error, arrays["teaching"])
    return {"first_second": round(start, 4), "last_second": round(end, 4), "falls": bool(end < start)}


def run_mirroring(seeds, learner: str, sizes: dict, out: Path) -> dict:
    spaces = Spaces(JOINTS_BOX, JOINTS_BOX)
    one, two, plots = [], [], {}
    for seed in tqdm(seeds, desc="mirroring, one teacher", file=sys.stderr):
        result = mirroring.one_teacher(seed, learner, max_teach=sizes["max_teach"])
        one.append({"seed": seed, "teach_s": result.teach_seconds, "final_err": result.final_error, "curve": result.curve})
        if seed == seeds[0]:
            plots["mirror_one"] = figure5(out, f"mirror_one_seed{seed}", result.trace,
                                          mirroring.figure5_error(result.trace, spaces),
                                          f"Mirroring, one teacher (seed {seed}): head error, rad", 15)
    for seed in tqdm(seeds, desc="mirroring, two teachers", file=sys.stderr):
        result = mirroring.two_teachers(seed, learner, seconds_each=sizes["seconds_each"])
        two.append({"seed": seed, "after_pan": result.curve[0][1], "final_err": result.final_error})
        if seed == seeds[0]:
            plots["mirror_two"] = figure5(out, f"mirror_two_seed{seed}", result.trace,
                                          mirroring.figure5_error(result.trace, spaces),
                                          f"Mirroring, pan then tilt teacher (seed {seed}): head error, rad", 15)
    return {"one": one, "two": two, "plots": plots}


def run_ballseeking(seeds, learner: str, sizes: dict, out: Path) -> dict:
    rows, plots = [], {}
    for seed in tqdm(seeds, desc="ball seeking + orange", file=sys.stderr):
        r = run_ballseek(seed, learner, n_episodes=sizes["episodes"], n_orange=sizes["orange"])
        rows.append({"seed": seed, "taught_s": r.teaching_seconds, "success": r.success, "reach_times": r.reach_times,
                     "orange_before": float(np.mean(r.orange_before)), "orange_after": float(np.mean(r.orange_after))})
        if seed == seeds[0]:
            plots["ballseek"] = figure5(out, f"ballseek_seed{seed}", r.trace, ballseek.figure5_error(r.trace, r.spaces),
                                        f"Ball seeking (seed {seed}): teacher vs student, RMS of half-range units",
                                        10)
    return {"rows": rows, "plots": plots}


def finite_or_none(value: float) -> float | None:
    """JSON has no infinity: a median over seeds that never got under the bound is null."""
    return float(value) if np.isfinite(value) else None


def summarise(mirror: dict, balls: dict, teacher_ceiling: float | None) -> dict:
    teach = [r["teach_s"] for r in mirror["one"]]
    reached = [t for t in teach if t is not None]
    two = [r["final_err"] for r in mirror["two"]]
    rows = balls["rows"]
    success = [r["success"] for r in rows]
    before, after = [r["orange_before"] for r in rows], [r["orange_after"] for r in rows]
    return {
        "seeds": len(teach),
        "mirror_teach_s_median": finite_or_none(np.median([np.inf if t is None else t for t in teach])),
        "mirror_teach_s_worst": max(reached) if len(reached) == len(teach) else None,
        "mirror_never_under": len(teach) - len(reached),
        "mirror_two_teachers_err": round(float(np.median(two)), 4),
        "mirror_two_teachers_err_worst": round(float(np.max(two)), 4),
        "ballseek_success": float(np.median(success)),
        "ballseek_success_worst": float(np.min(success)),
        "ballseek_teacher_success": teacher_ceiling,
        "orange_before": float(np.median(before)),
        "orange_before_worst": float(np.min(before)),
        "orange_after": float(np.median(after)),
        "orange_after_worst": float(np.max(after)),
        "figure5_error_falls": {k: v["falls"] for k, v in {**mirror["plots"], **balls["plots"]}.items()},
    }


def table(s: dict, quick: bool) -> str:
    def sec(v):
        return "never" if v is None else f"{v:.1f} s"
    lines = [f"{'figure':44} {'median':>9} {'worst':>9}  paper / target", "-" * 92,
             f"{'1 mirroring, teaching until held-out < 0.05':44} {sec(s['mirror_teach_s_median']):>9} "
             f"{sec(s['mirror_teach_s_worst']):>9}  < 10 s / < 5 s",
             f"{'2 two teachers in turn, held-out RMS (rad)':44} {s['mirror_two_teachers_err']:>9.3f} "
             f"{s['mirror_two_teachers_err_worst']:>9.3f}  merges both / < 0.05",
             f"{'3 ball seeking, student success':44} {s['ballseek_success']:>9.0%} {s['ballseek_success_worst']:>9.0%}"
             f"  works after < 1 min / >= 90%",
             f"{'4 approaches orange, before correction':44} {s['orange_before']:>9.0%} {s['orange_before_worst']:>9.0%}"
             f"  approaches it / most",
             f"{'4 approaches orange, after <= 20 s correction':44} {s['orange_after']:>9.0%} {s['orange_after_worst']:>9.0%}"
             f"  ignores it / <= 10%",
             f"{'5 Figure 5 error falls while taught':44} {str(all(s['figure5_error_falls'].values())):>9}"]
    if s["ballseek_teacher_success"] is not None:
        lines.append(f"   (teacher's own success on seed 0's episodes: {s['ballseek_teacher_success']:.0%})")
    lines.append(f"   seeds: {s['seeds']}{' (quick: shortened runs)' if quick else ''}")
    return "\n".join(lines)


def main(seeds: int, quick: bool, out: Path, learner: str) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    sizes = QUICK if quick else FULL
    seed_list = list(range(min(seeds, 2) if quick else seeds))
    started = time.perf_counter()
    mirror = run_mirroring(seed_list, learner, sizes, out)
    balls = run_ballseeking(seed_list[:1] if quick else seed_list, learner, sizes, out)
    ceiling = None if quick else teacher_success(0, sizes["episodes"])
    summary = summarise(mirror, balls, ceiling)
    summary["wall_s"] = round(time.perf_counter() - started, 1)
    (out / "results.json").write_text(json.dumps({"summary": summary, "mirror": mirror, "ballseek": balls}, indent=1,
                                                 default=float))
    print(table(summary, quick))
    print(f"plots and data: {out}")
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=10, help="seeds per experiment (default 10)")
    parser.add_argument("--quick", action="store_true", help="shortened runs, a minute or two")
    parser.add_argument("--out", type=Path, default=None, help="where PNGs and data go (default runs/experiments-<time>/)")
    parser.add_argument("--learner", default="lwpr", help="learner of every experiment (default lwpr)")
    args = parser.parse_args()
    out = args.out or Path("runs") / time.strftime("experiments-%Y%m%d-%H%M%S")
    print(json.dumps(main(args.seeds, args.quick, out, args.learner)))
