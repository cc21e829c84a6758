"""The paper's experiments, measured: mirroring (one teacher; two teachers in turn), ball seeking
and the orange ball, over several seeds, single process, simulated time as fast as it goes.

    .venv/bin/python benchmarks/experiments.py [--seeds 10] [--quick] [--out DIR]

The system as wired: each experiment's learner is read from its deploy profile (per-output GP for
mirroring, the GP with near=0.2 for ball seeking, on the colour-blind slot layout); --learner NAME
runs every experiment with that learner instead. Baselines measured in the
same run: the teacher's own success on the student's episodes, and two contrasts that show why
the wiring is what it is (whole-vector training for two teachers; the per-colour layout for the
orange ball). Beside the scheduled 20 s correction, a few seeds leave it to the robot's initiative:
the person teaches only when asked (green ears). Prints a table, writes the Figure 5 PNGs and every
trace under --out, and ends with one JSON line of the figures.
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

from bus_schema.spaces import Spaces  # noqa: E402
from services.experiments import ballseek, mirroring  # noqa: E402
from services.experiments.ballseek_protocol import run_ballseek, teacher_success  # noqa: E402
from services.experiments.evaluate import first_band_drop, percent, plot_error  # noqa: E402
from services.experiments.wiring import wired_learner  # noqa: E402
from services.platforms.aibo.platform import JOINTS_BOX  # noqa: E402

FULL = {"max_teach": 12.0, "seconds_each": 10.0, "episodes": 20, "orange": 5, "pink_after": 5, "contrast_seeds": 3}
QUICK = {"max_teach": 6.0, "seconds_each": 6.0, "episodes": 3, "orange": 2, "pink_after": 1, "contrast_seeds": 1}


def figure5(out: Path, name: str, trace, error, title: str, window: int, phases: dict | None = None) -> dict:
    """Save the PNG and the trace; say whether the error fell during the first teaching span."""
    arrays = trace.arrays()
    np.savez_compressed(out / f"{name}.npz", error=error, **arrays)
    plot_error(out / f"{name}.png", arrays["t"], error, arrays["teaching"], title, smooth_window=window, phases=phases,
               asking=arrays["mode"] == "unsure")
    start, end = first_band_drop(arrays["t"], error, arrays["teaching"])
    return {"png": f"{name}.png", "first_second": round(start, 4), "last_second": round(end, 4),
            "falls": bool(end < start)}


def run_mirroring(seeds, learner: tuple[str, dict], sizes: dict, out: Path) -> dict:
    spaces = Spaces(JOINTS_BOX, JOINTS_BOX)
    one, two, plots = [], [], {}
    for seed in tqdm(seeds, desc="mirroring, one teacher", file=sys.stderr):
        result = mirroring.one_teacher(seed, learner[0], max_teach=sizes["max_teach"], **learner[1])
        one.append({"seed": seed, "teach_s": result.teach_seconds, "final_err": result.final_error,
                    "curve": result.curve})
        if seed == seeds[0]:
            plots["mirror_one"] = figure5(out, f"mirror_one_seed{seed}", result.trace,
                                          mirroring.mirroring_error(result.trace, spaces),
                                          f"Mirroring, one teacher (seed {seed}): head error, rad", 15)
    for seed in tqdm(seeds, desc="mirroring, two teachers", file=sys.stderr):
        row = {"seed": seed}
        for masked, tag in ((True, ""), (False, "_whole_vector")):
            result = mirroring.two_teachers(seed, learner[0], seconds_each=sizes["seconds_each"], masked=masked,
                                            **learner[1])
            row.update({f"after_pan{tag}": result.curve[0][1], f"final_err{tag}": result.final_error})
            if seed == seeds[0]:
                how = "per-output learner" if masked else "whole vector trained (contrast)"
                plots[f"mirror_two{tag}"] = figure5(out, f"mirror_two{tag}_seed{seed}", result.trace,
                                                    mirroring.mirroring_error(result.trace, spaces),
                                                    f"Mirroring, pan then tilt teacher, {how} (seed {seed})", 15)
        two.append(row)
    return {"one": one, "two": two, "plots": plots}


def run_ballseeking(seeds, learner: tuple[str, dict], sizes: dict, out: Path, inputs: str, episodes: int,
                    correction: str = "scheduled") -> dict:
    """The whole V.B protocol per seed; `episodes` = 0 runs teaching and the orange ball only;
    `correction` "answers" leaves the orange correction to the robot's requests."""
    rows, plots = [], {}
    what = "ball seeking + orange" if episodes else "orange only"
    name = f"ballseek_{inputs}" + ("" if correction == "scheduled" else f"_{correction}")
    for seed in tqdm(seeds, desc=f"{what}, {inputs} layout, {correction} correction", file=sys.stderr):
        r = run_ballseek(seed, learner[0], n_episodes=episodes, n_orange=sizes["orange"], inputs=inputs,
                         n_pink_after=sizes["pink_after"], correction=correction, **learner[1])
        row = {"seed": seed, "taught_s": r.teaching_seconds, "reach_times": r.reach_times,
               "orange_before": r.orange_before, "orange_after": r.orange_after,
               "pink_after": [t is not None for t in r.pink_after],
               "correction_taught_s": r.taught_seconds("correction"),
               "asks_pink": r.asking("pink alone", "pink"), "asks_orange_before": r.asking("orange", "orange"),
               "asks_orange_after": r.asking("orange after", "orange")}
        if episodes:
            row["success"] = r.success
            row["teacher_success"] = teacher_success(seed, episodes, inputs=inputs)
            row["teacher_success_anywhere"] = teacher_success(seed, episodes, inputs=inputs, in_view=False)
            row["teacher_pink_after"] = teacher_success(seed, sizes["pink_after"], inputs=inputs, phase="pink_after")
        rows.append(row)
        if seed == seeds[0]:
            plots[name] = figure5(out, f"{name}_seed{seed}", r.trace, ballseek.ballseek_error(r.trace, r.spaces,
                                                                                              r.teacher),
                                  f"Ball seeking, {inputs} layout, {correction} correction (seed {seed}): "
                                  "RMS error / half range", 10, r.phases)
    return {"rows": rows, "plots": plots}


def finite_or_none(value: float) -> float | None:
    """JSON has no infinity: a median over seeds that never got under the bound is null."""
    return float(value) if np.isfinite(value) else None


def orange_figures(rows: list, tag: str) -> dict:
    """Fraction of orange-only episodes where the student reached the orange ball, and of pink
    episodes after the correction where it reached pink, pooled over seeds, and the worst seed
    (before correction the worst is the fewest; after, the most; pink after: the fewest)."""
    figures = {}
    for name, key, worst in (("orange_before", "orange_before", np.min), ("orange_after", "orange_after", np.max),
                             ("pink_after", "pink_after_correction", np.min)):
        figures[f"{key}{tag}"] = round(float(np.mean(np.concatenate([r[name] for r in rows]))), 3)
        figures[f"{key}{tag}_worst"] = round(float(worst([np.mean(r[name]) for r in rows])), 3)
    return figures


def asking_figures(rows: list) -> dict:
    """How often the student alone asked for teaching with a ball in view (fraction of those ticks):
    median over seeds and the worst seed (asking with pink or after the correction: the most;
    asking with orange before it: the fewest)."""
    def column(name):
        return [r[name] for r in rows if r[name] is not None]
    figures = {}
    for name, worst in (("asks_pink", max), ("asks_orange_before", min), ("asks_orange_after", max)):
        values = column(name)
        figures[name] = round(float(np.median(values)), 3) if values else None
        figures[f"{name}_worst"] = round(float(worst(values)), 3) if values else None
    return figures


def summarise(mirror: dict, balls: dict, contrast: dict, answered: dict) -> dict:
    teach = [r["teach_s"] for r in mirror["one"]]
    reached = [t for t in teach if t is not None]
    two = [r["final_err"] for r in mirror["two"]]
    whole = [r["final_err_whole_vector"] for r in mirror["two"]]
    success = [r["success"] for r in balls["rows"]]
    ceiling = [r["teacher_success"] for r in balls["rows"]]
    anywhere = [r["teacher_success_anywhere"] for r in balls["rows"]]
    return {
        "seeds": len(teach),
        "mirror_teach_s_median": finite_or_none(np.median([np.inf if t is None else t for t in teach])),
        "mirror_teach_s_worst": max(reached) if len(reached) == len(teach) else None,
        "mirror_never_under": len(teach) - len(reached),
        "mirror_two_teachers_err": round(float(np.median(two)), 4),
        "mirror_two_teachers_err_worst": round(float(np.max(two)), 4),
        "mirror_two_teachers_err_whole_vector": round(float(np.median(whole)), 4),
        "mirror_two_teachers_err_whole_vector_worst": round(float(np.max(whole)), 4),
        "ballseek_success": float(np.median(success)),
        "ballseek_success_worst": float(np.min(success)),
        "ballseek_success_pooled": round(float(np.mean(success)), 3),
        "ballseek_teacher_success": round(float(np.mean(ceiling)), 3),
        "ballseek_teacher_success_worst": float(np.min(ceiling)),
        "ballseek_student_over_teacher": round(float(np.mean(success) / max(np.mean(ceiling), 1e-9)), 3),
        "ballseek_teacher_success_anywhere": round(float(np.mean(anywhere)), 3),
        "ballseek_teacher_success_anywhere_worst": float(np.min(anywhere)),
        **orange_figures(balls["rows"], ""),
        **asking_figures(balls["rows"]),
        "pink_after_correction_teacher": round(float(np.mean([r["teacher_pink_after"] for r in balls["rows"]])), 3),
        **orange_figures(contrast["rows"], "_colours"),
        "orange_colours_seeds": len(contrast["rows"]),
        **orange_figures(answered["rows"], "_answers"),
        "orange_answers_taught_s": float(np.median([r["correction_taught_s"] for r in answered["rows"]])),
        "orange_answers_taught_s_worst": float(np.max([r["correction_taught_s"] for r in answered["rows"]])),
        "orange_answers_seeds": len(answered["rows"]),
        "figure5_error_falls": {k: v["falls"] for k, v in {**mirror["plots"], **balls["plots"], **contrast["plots"],
                                                           **answered["plots"]}.items()},
    }


def table(s: dict, sizes: dict) -> str:
    def sec(v):
        return "never" if v is None else f"{v:.1f} s"

    def row(name, median, worst, claim):
        return f"{name:62} {median:>8} {worst:>8}  {claim}"

    def share(name, key, claim=""):  # a fraction: the figure and its worst seed, as percentages
        return row(name, percent(s[key]), percent(s.get(f"{key}_worst")), claim)
    lines = [row("figure", "median", "worst", "paper / target"), "-" * 112,
             row("1 mirroring: teaching until held-out RMS < 0.05 rad", sec(s["mirror_teach_s_median"]),
                 sec(s["mirror_teach_s_worst"]), "< 10 s / < 5 s"),
             row("2 two teachers in turn, held-out RMS (rad)", f"{s['mirror_two_teachers_err']:.4f}",
                 f"{s['mirror_two_teachers_err_worst']:.4f}", "merges both / < 0.05"),
             row("    contrast: the whole output vector trained", f"{s['mirror_two_teachers_err_whole_vector']:.3f}",
                 f"{s['mirror_two_teachers_err_whole_vector_worst']:.3f}", ""),
             share(f"3 ball seeking: student reaches pink, {sizes['episodes']} episodes of 30 s", "ballseek_success",
                   "works after < 1 min / >= 90%"),
             share("    baseline: the teacher itself on the same episodes", "ballseek_teacher_success",
                   f"student / teacher {s['ballseek_student_over_teacher']:.2f}"),
             share("    contrast: the teacher, balls behind the clutter too", "ballseek_teacher_success_anywhere",
                   "(a person puts the ball in view)"),
             share("4 approaches orange before correction (pooled)", "orange_before", "approaches it / most"),
             share("4 approaches orange after 20 s of correction (pooled)", "orange_after", "ignores it / <= 10%"),
             share("4 asks for teaching, orange in view, before correction (ticks)", "asks_orange_before",
                   "requests education (Fig. 4d)"),
             share("4 asks for teaching, orange in view, after correction", "asks_orange_after"),
             share("    asks for teaching, pink in view, student alone", "asks_pink", "sure of what it was taught"),
             share("    after the correction, reaches pink (pooled)", "pink_after_correction", "responds only to pink"),
             row("      baseline: the teacher on the same episodes", percent(s["pink_after_correction_teacher"]), "",
                 ""),
             row(f"    correction by answering its requests ({s['orange_answers_seeds']} seeds): teaching",
                 f"{s['orange_answers_taught_s']:.1f} s", f"{s['orange_answers_taught_s_worst']:.1f} s",
                 "short (< 10 s) activations"),
             share("      then approaches orange (pooled)", "orange_after_answers"),
             share("      then reaches pink (pooled)", "pink_after_correction_answers"),
             share(f"    contrast: per-colour layout, before ({s['orange_colours_seeds']} seeds)",
                   "orange_before_colours"),
             share("    contrast: per-colour layout, after", "orange_after_colours"),
             row("5 Figure 5: error falls in the first teaching span",
                 f"{sum(s['figure5_error_falls'].values())}/{len(s['figure5_error_falls'])}", "", "falls / every plot"),
             f"   seeds: {s['seeds']}{' (quick: shortened runs, fewer episodes)' if sizes is QUICK else ''}"]
    return "\n".join(lines)


def main(seeds: int, quick: bool, out: Path, learner: str | None) -> dict:
    """learner None: each experiment's learner as its deploy profile wires it; a name: that learner."""
    out.mkdir(parents=True, exist_ok=True)
    sizes = QUICK if quick else FULL
    seed_list = list(range(min(seeds, 2) if quick else seeds))
    started = time.perf_counter()
    mirror_learner = wired_learner("mirroring") if learner is None else (learner, {})
    ball_learner = wired_learner("ballseek") if learner is None else (learner, {})
    mirror = run_mirroring(seed_list, mirror_learner, sizes, out)
    ball_seeds = seed_list[:1] if quick else seed_list
    balls = run_ballseeking(ball_seeds, ball_learner, sizes, out, "slots", sizes["episodes"])
    contrast = run_ballseeking(seed_list[:sizes["contrast_seeds"]], ball_learner, sizes, out, "colours", 0)
    answered = run_ballseeking(seed_list[:sizes["contrast_seeds"]], ball_learner, sizes, out, "slots", 0, "answers")
    summary = summarise(mirror, balls, contrast, answered)
    summary["learners"] = {"mirroring": list(mirror_learner), "ballseek": list(ball_learner)}
    summary["wall_s"] = round(time.perf_counter() - started, 1)
    (out / "results.json").write_text(json.dumps({"summary": summary, "mirror": mirror, "ballseek": balls,
                                                  "orange_colours": contrast, "orange_answers": answered},
                                                 indent=1, default=float))
    print(table(summary, sizes))
    print(f"plots and data: {out}")
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=10, help="seeds per experiment (default 10)")
    parser.add_argument("--quick", action="store_true", help="shortened runs, a minute or two")
    parser.add_argument("--out", type=Path, default=None,
                        help="where PNGs and data go (default runs/experiments-<time>/)")
    parser.add_argument("--learner", default=None,
                        help="learner of every experiment (default: each as its deploy profile wires it)")
    args = parser.parse_args()
    out = args.out or Path("runs") / time.strftime("experiments-%Y%m%d-%H%M%S")
    print(json.dumps(main(args.seeds, args.quick, out, args.learner)))
