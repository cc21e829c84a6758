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
LAYOUTS = {"colours": "detector layout (as wired)", "slots": "colour-blind slots (blob_slots.py)"}


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
        row = {"seed": seed}
        for masked in (False, True):
            result = mirroring.two_teachers(seed, learner, seconds_each=sizes["seconds_each"], masked=masked)
            tag = "_masked" if masked else ""
            row.update({f"after_pan{tag}": result.curve[0][1], f"final_err{tag}": result.final_error})
            if seed == seeds[0]:
                how = "only taught outputs trained (proposal)" if masked else "as wired"
                plots[f"mirror_two{tag}"] = figure5(out, f"mirror_two{tag}_seed{seed}", result.trace,
                                                    mirroring.figure5_error(result.trace, spaces),
                                                    f"Mirroring, pan then tilt teacher, {how} (seed {seed})", 15)
        two.append(row)
    return {"one": one, "two": two, "plots": plots}


def run_ballseeking(seeds, learner: str, sizes: dict, out: Path, inputs: str, episodes: int) -> dict:
    rows, plots = [], {}
    for seed in tqdm(seeds, desc=f"ball seeking + orange, {inputs}", file=sys.stderr):
        r = run_ballseek(seed, learner, n_episodes=episodes, n_orange=sizes["orange"], inputs=inputs)
        rows.append({"seed": seed, "taught_s": r.teaching_seconds, "success": r.success if episodes else None,
                     "reach_times": r.reach_times, "orange_before": r.orange_before, "orange_after": r.orange_after})
        if seed == seeds[0]:
            plots[f"ballseek_{inputs}"] = figure5(out, f"ballseek_{inputs}_seed{seed}", r.trace,
                                                  ballseek.figure5_error(r.trace, r.spaces, r.teacher),
                                                  f"Ball seeking, {LAYOUTS[inputs]} (seed {seed}): teacher vs student",
                                                  10)
    return {"rows": rows, "plots": plots}


def finite_or_none(value: float) -> float | None:
    """JSON has no infinity: a median over seeds that never got under the bound is null."""
    return float(value) if np.isfinite(value) else None


def orange_figures(rows: list, tag: str) -> dict:
    """Pooled fraction of orange-only episodes where the student reached the orange ball, and the
    worst seed (most approaches before would be best, so its worst is the fewest; after, the most)."""
    before = [np.mean(r["orange_before"]) for r in rows]
    after = [np.mean(r["orange_after"]) for r in rows]
    return {f"orange_before{tag}": round(float(np.mean(np.concatenate([r["orange_before"] for r in rows]))), 3),
            f"orange_before{tag}_worst": round(float(np.min(before)), 3),
            f"orange_after{tag}": round(float(np.mean(np.concatenate([r["orange_after"] for r in rows]))), 3),
            f"orange_after{tag}_worst": round(float(np.max(after)), 3)}


def summarise(mirror: dict, colours: dict, slots: dict, teacher_ceiling: float | None) -> dict:
    teach = [r["teach_s"] for r in mirror["one"]]
    reached = [t for t in teach if t is not None]
    two = [r["final_err"] for r in mirror["two"]]
    two_masked = [r["final_err_masked"] for r in mirror["two"]]
    success = [r["success"] for r in colours["rows"]]
    return {
        "seeds": len(teach),
        "mirror_teach_s_median": finite_or_none(np.median([np.inf if t is None else t for t in teach])),
        "mirror_teach_s_worst": max(reached) if len(reached) == len(teach) else None,
        "mirror_never_under": len(teach) - len(reached),
        # the system as wired: partial teachers train only their outputs (per-output learner)
        "mirror_two_teachers_err": round(float(np.median(two_masked)), 4),
        "mirror_two_teachers_err_worst": round(float(np.max(two_masked)), 4),
        "mirror_two_teachers_err_whole_vector": round(float(np.median(two)), 4),
        "mirror_two_teachers_err_whole_vector_worst": round(float(np.max(two)), 4),
        "ballseek_success": float(np.median(success)),
        "ballseek_success_worst": float(np.min(success)),
        "ballseek_success_pooled": round(float(np.mean(success)), 3),
        "ballseek_teacher_success": teacher_ceiling,
        # orange as wired for the experiment: perception --layout slots (colour an input)
        **orange_figures(slots["rows"], ""),
        **orange_figures(colours["rows"], "_colours"),
        "figure5_error_falls": {k: v["falls"] for k, v in {**mirror["plots"], **colours["plots"], **slots["plots"]}.items()},
    }


def table(s: dict, quick: bool) -> str:
    def sec(v):
        return "never" if v is None else f"{v:.1f} s"

    def row(name, median, worst, claim):
        return f"{name:60} {median:>8} {worst:>8}  {claim}"
    lines = [row("figure", "median", "worst", "paper / target"), "-" * 114,
             row("1 mirroring: teaching until held-out RMS < 0.05 rad", sec(s["mirror_teach_s_median"]),
                 sec(s["mirror_teach_s_worst"]), "< 10 s / < 5 s"),
             row("2 two teachers in turn, held-out RMS (rad), per-output", f"{s['mirror_two_teachers_err']:.3f}",
                 f"{s['mirror_two_teachers_err_worst']:.3f}", "merges both / < 0.05"),
             row("  same, whole output vector trained (before)", f"{s['mirror_two_teachers_err_whole_vector']:.3f}",
                 f"{s['mirror_two_teachers_err_whole_vector_worst']:.3f}", "merges both / < 0.05"),
             row("3 ball seeking: student success, 30 s episodes", f"{s['ballseek_success']:.0%}",
                 f"{s['ballseek_success_worst']:.0%}", "works after < 1 min / >= 90%")]
    for tag, name in (("", "colour-blind slots"), ("_colours", "per-colour layout")):
        lines += [row(f"4 approaches orange before correction, {name}", f"{s['orange_before' + tag]:.0%}",
                      f"{s['orange_before' + tag + '_worst']:.0%}", "approaches it / most"),
                  row(f"4 approaches orange after 20 s correction, {name}", f"{s['orange_after' + tag]:.0%}",
                      f"{s['orange_after' + tag + '_worst']:.0%}", "ignores it / <= 10%")]
    lines.append(row("5 Figure 5: error falls in the first teaching span", str(all(s["figure5_error_falls"].values())),
                     "", "falls / every plot"))
    lines.append("   orange: pooled over all episodes (median column) and the worst seed")
    if s["ballseek_teacher_success"] is not None:
        lines.append(f"   teacher's own success on seed 0's 30 s episodes: {s['ballseek_teacher_success']:.0%}")
    lines.append(f"   seeds: {s['seeds']}{' (quick: shortened runs, ball seeking on one seed)' if quick else ''}")
    return "\n".join(lines)


def main(seeds: int, quick: bool, out: Path, learner: str) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    sizes = QUICK if quick else FULL
    seed_list = list(range(min(seeds, 2) if quick else seeds))
    started = time.perf_counter()
    mirror = run_mirroring(seed_list, learner, sizes, out)
    ball_seeds = seed_list[:1] if quick else seed_list
    colours = run_ballseeking(ball_seeds, learner, sizes, out, "colours", sizes["episodes"])
    slots = run_ballseeking(ball_seeds, learner, sizes, out, "slots", 0)  # the orange experiment only
    ceiling = None if quick else teacher_success(0, sizes["episodes"])
    summary = summarise(mirror, colours, slots, ceiling)
    summary["wall_s"] = round(time.perf_counter() - started, 1)
    (out / "results.json").write_text(json.dumps({"summary": summary, "mirror": mirror, "colours": colours,
                                                  "slots": slots}, indent=1, default=float))
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
