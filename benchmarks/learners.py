"""Benchmark every registered learner on the LWPR tutorial's cross and the paper's mirroring.

Prints a table (learner x task: accuracy, size, updates/s, predictions/s), the reference
library's figures beside ours, then LWPR over 10 independent data draws per protocol (median and
worst) beside the reference library on the same draws, where one LWPR call's time goes
(benchmarks/lib/lwpr_percall.py), and as its LAST line one JSON object of the figures. `--quick`
runs in a minute or two (the two slower protocols over 3 draws); progress bars go to stderr.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: rigs.*, benchmarks.*
import services  # noqa: E402,F401  (first: one BLAS thread per process, see services/__init__.py)

import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from services.learners import LEARNERS, make_learner  # noqa: E402
from benchmarks.lib import lwpr_percall, lwpr_reference, lwpr_versus  # noqa: E402
from rigs.tasks import (  # noqa: E402
    CROSS_LWPR_PARAMS, cross, cross_embedded, cross_grid, cross_training, mirror_samples, nmse,
    three_outputs, three_outputs_samples, worst_error,
)

# Klanke, Vijayakumar & Schaal's LWPR library v1.2.6 through its Python binding, this kind of machine
REFERENCE = {"cross_nmse": 0.043, "cross_rfs": 41, "cross_updates_per_s": 568e3,
             "cross_predictions_per_s": 0.97e6, "mirror_samples_to_005": 9000,
             "mirror_updates_per_s": 150e3}
CROSS_PARAMS = {"lwpr": CROSS_LWPR_PARAMS, "sogp": {"length_scale": 0.15, "noise_var": 0.01}, "knn": {}}
THRESHOLD = 0.05  # rad, worst case over the held-out points


def warm_up(model, xs: np.ndarray, ys: np.ndarray) -> None:
    """Load compiled kernels before the clock starts (first-call cost is reported apart)."""
    twin = model.clone()
    twin.learn_one(xs[0], ys[0])
    twin.learn_many(xs[:2], ys[:2])
    twin.predict_one(xs[0])
    twin.predict_many(xs[:2])


def best_rate(work, count: int, repeats: int = 3) -> float:
    """Items per second of the fastest of `repeats` runs: the machine is shared, and the
    fastest run is the one least disturbed by other processes."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        work()
        best = min(best, time.perf_counter() - start)
    return count / best


def learn_each(model, xs: np.ndarray, ys: np.ndarray) -> None:
    for x, y in zip(xs, ys):
        model.learn_one(x, y)


def predict_each(model, xs: np.ndarray) -> None:
    for x in xs:
        model.predict_one(x)


def bench_cross(name: str, epochs: int) -> dict:
    xs, ys = cross_training(500, seed=0)
    model = make_learner(name, 2, 1, seed=0, **CROSS_PARAMS.get(name, {}))
    order = np.random.default_rng(1).permutation(np.tile(np.arange(500), epochs))
    xs, ys = xs[order], ys[order]
    warm_up(model, xs, ys)
    for x, y in tqdm(zip(xs, ys), total=len(xs), desc=f"{name} cross", leave=False, file=sys.stderr):
        model.learn_one(x, y)
    grid, truth = cross_grid()
    prediction = model.predict_many(grid)
    return {"nmse": nmse(prediction.y, truth), "rfs": model.size,
            "updates_per_s": best_rate(lambda: learn_each(model.clone(), xs, ys), len(xs)),
            "batch_updates_per_s": best_rate(lambda: model.clone().learn_many(xs, ys), len(xs)),
            "predictions_per_s": best_rate(lambda: predict_each(model, grid), len(grid)),
            "batch_predictions_per_s": best_rate(lambda: model.predict_many(grid), len(grid))}


def bench_mirror(name: str, samples: int) -> dict:
    """Stream demonstrations one at a time; watch the worst held-out error."""
    model = make_learner(name, 18, 18, seed=0)
    xs, ys = mirror_samples(samples, seed=0)
    held_out, truth = mirror_samples(1000, seed=1)
    first_under, under_since = None, None
    warm_up(model, xs, ys)
    for i in tqdm(range(samples), desc=f"{name} mirror", leave=False, file=sys.stderr):
        model.learn_one(xs[i], ys[i])
        seen = i + 1
        if seen % (10 if seen <= 1000 else 250) == 0 or seen == samples:
            error = worst_error(model.predict_many(held_out).y, truth)
            if error < THRESHOLD:
                first_under = first_under or seen
                under_since = under_since or seen
            else:
                under_since = None
    final = model.predict_many(held_out)
    return {"samples_to_005": first_under, "stays_under_from": under_since,
            "worst_error": worst_error(final.y, truth), "size": model.size,
            # demonstration rate: learn_one over the first 5000 samples from scratch
            "updates_per_s": best_rate(lambda: learn_each(model.clone(), xs[:5000], ys[:5000]), min(samples, 5000)),
            "confidence": float(np.median(final.confidence)),
            "snapshot_bytes": len(model.snapshot())}


def bench_untuned(name: str, samples: int) -> dict:
    """Default hyper-parameters on maps neither task above tunes for: cross among 8
    irrelevant inputs, and 3 outputs of 12 inputs each using different ones."""
    figures = {}
    for task, (xs, ys), truth_of, n_in in (
        ("cross10", cross_embedded(samples, seed=2), lambda x: cross(x[:, :2]), 10),
        ("multi3", three_outputs_samples(samples, seed=3), three_outputs, 12),
    ):
        model = make_learner(name, n_in, ys.shape[1], seed=0)
        start = time.perf_counter()
        model.learn_many(xs, ys)
        seconds = time.perf_counter() - start
        test = np.random.default_rng(4).uniform(-1.0, 1.0, (2000, n_in))
        figures[f"{task}_nmse"] = nmse(model.predict_many(test).y, truth_of(test))
        figures[f"{task}_size"] = model.size
        figures[f"{task}_batch_updates_per_s"] = samples / seconds
    return figures


def first_call_seconds(name: str, cold: bool) -> float:
    """Import, build, first learn_one and predict_one in a fresh process (cold: empty numba cache)."""
    code = ("import time,numpy as np;t=time.perf_counter();from services.learners import make_learner;"
            f"m=make_learner('{name}',18,18);m.learn_one(np.zeros(18),np.zeros(18));m.predict_one(np.zeros(18));"
            "print(time.perf_counter()-t)")
    env = dict(os.environ)
    with tempfile.TemporaryDirectory() as cache:
        if cold:
            env["NUMBA_CACHE_DIR"] = cache
        out = subprocess.run([sys.executable, "-c", code], cwd=Path(__file__).resolve().parents[1],
                             env=env, capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def main(quick: bool, reference_source: Path | None = None) -> dict:
    epochs, samples = (5, 2000) if quick else (20, 15000)
    figures: dict = {}
    rows = []
    for name in tqdm(list(LEARNERS), desc="learners", file=sys.stderr):
        c = bench_cross(name, epochs)
        m = bench_mirror(name, samples if name == "lwpr" or not quick else 1000)
        u = bench_untuned(name, 2000 if quick else 5000)
        warm = first_call_seconds(name, cold=False)
        cold = warm if quick else first_call_seconds(name, cold=True)
        for key, value in c.items():
            figures[f"{name}_cross_{key}"] = value
        for key, value in m.items():
            figures[f"{name}_mirror_{key}"] = value
        figures.update({f"{name}_{key}": value for key, value in u.items()})
        figures[f"{name}_first_call_s"], figures[f"{name}_first_call_cold_s"] = warm, cold
        rows.append((name, c, m, u, warm, cold))
    print_table(rows, epochs)
    if "lwpr_cross_nmse" in figures:
        print_closing_note(figures, epochs)
        draws = 10
        mine = lwpr_versus.ours(draws, slow_draws=3 if quick else draws)
        theirs, provenance = lwpr_versus.reference(draws, reference_source)
        figures.update(lwpr_versus.table(mine, theirs, provenance))
        calls = {**lwpr_percall.per_call(), **lwpr_percall.batch_rates()}
        if reference_source is not None:
            calls.update(lwpr_percall.reference_rates(reference_source))
        lwpr_percall.table(calls)
        figures.update({key if key.startswith("reference") else f"lwpr_{key}": value for key, value in calls.items()})
    return figures


def print_table(rows, epochs: int) -> None:
    print(f"cross: 500 noisy points x {epochs} epochs, nMSE on the 41x41 noise-free grid; "
          "mirror: 18 -> 18, worst |error| over 1000 held-out points")
    print(f"{'learner':8} {'cross nMSE':>10} {'size':>5} {'upd/s':>9} {'upd/s batch':>11} {'pred/s':>9} "
          f"{'pred/s batch':>12} | {'mirror <0.05 at':>15} {'stays from':>10} {'worst':>7} {'upd/s':>8} "
          f"{'size':>5} {'MB':>6} | {'1st call s':>10}")
    ref = REFERENCE
    print(f"{'ref C':8} {ref['cross_nmse']:>10.3f} {ref['cross_rfs']:>5} {ref['cross_updates_per_s']:>9.0f} "
          f"{'':>11} {ref['cross_predictions_per_s']:>9.0f} {'':>12} | {'~9000':>15} {'~14000':>10} "
          f"{'':>7} {ref['mirror_updates_per_s']:>8.0f}")
    for name, c, m, _, warm, cold in rows:
        print(f"{name:8} {c['nmse']:>10.3f} {c['rfs']:>5} {c['updates_per_s']:>9.0f} {c['batch_updates_per_s']:>11.0f} "
              f"{c['predictions_per_s']:>9.0f} {c['batch_predictions_per_s']:>12.0f} | "
              f"{str(m['samples_to_005']):>15} {str(m['stays_under_from']):>10} {m['worst_error']:>7.3f} "
              f"{m['updates_per_s']:>8.0f} {m['size']:>5} {m['snapshot_bytes'] / 1e6:>6.2f} | "
              f"{warm:>5.2f}/{cold:.1f}")
    print("rates: fastest of 3 runs (shared machine); mirror upd/s = learn_one over its first 5000 samples")
    print("first call = import + build + first learn/predict in a fresh process, warm/cold numba cache")
    print()
    print("default hyper-parameters (no tuning): cross10 = cross among 8 irrelevant inputs, "
          "multi3 = 12 inputs -> 3 outputs; nMSE on 2000 held-out points")
    print(f"{'learner':8} {'cross10 nMSE':>12} {'size':>5} {'multi3 nMSE':>12} {'size':>5}")
    for name, _, _, u, _, _ in rows:
        print(f"{name:8} {u['cross10_nmse']:>12.3f} {u['cross10_size']:>5} {u['multi3_nmse']:>12.3f} "
              f"{u['multi3_size']:>5}")


def print_closing_note(figures: dict, epochs: int) -> None:
    """Our LWPR beside the reference library, figure by figure."""
    ref = REFERENCE
    pairs = [
        ("cross nMSE (lower is better)", figures["lwpr_cross_nmse"], ref["cross_nmse"], ".3f"),
        ("cross receptive fields", figures["lwpr_cross_rfs"], ref["cross_rfs"], "d"),
        ("cross updates/s, learn_one", figures["lwpr_cross_updates_per_s"], ref["cross_updates_per_s"], ",.0f"),
        ("cross updates/s, learn_many", figures["lwpr_cross_batch_updates_per_s"], ref["cross_updates_per_s"], ",.0f"),
        ("cross predictions/s, predict_one", figures["lwpr_cross_predictions_per_s"], ref["cross_predictions_per_s"],
         ",.0f"),
        ("cross predictions/s, predict_many", figures["lwpr_cross_batch_predictions_per_s"],
         ref["cross_predictions_per_s"], ",.0f"),
        ("mirror samples to < 0.05 rad", figures["lwpr_mirror_samples_to_005"] or float("nan"),
         ref["mirror_samples_to_005"], ",.0f"),
        ("mirror updates/s", figures["lwpr_mirror_updates_per_s"], ref["mirror_updates_per_s"], ",.0f"),
    ]
    print()
    print("LWPR beside the reference C library (v1.2.6 through its Python binding)"
          + ("" if epochs == 20 else f"; cross here after {epochs} epochs, the reference's after 20") + ":")
    for label, ours, theirs, fmt in pairs:
        print(f"  {label:36} ours {ours:>12{fmt}}   reference {theirs:>12{fmt}}   ratio {ours / theirs:5.2f}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer epochs and samples (a minute or two)")
    parser.add_argument("--reference-source", type=Path, default=None,
                        help="a checkout of the reference LWPR library (github.com/ipab-slmc/lwpr) to build and "
                             "measure on the same draws; without it its recorded figures are shown")
    arguments = parser.parse_args()
    if arguments.reference_source is not None and (missing := lwpr_reference.missing_files(arguments.reference_source)):
        parser.error(f"--reference-source {arguments.reference_source} is not a checkout of ipab-slmc/lwpr "
                     f"(no {', '.join(missing[:3])}); a bare git mirror needs a work tree: git worktree add")
    print(json.dumps(main(arguments.quick, arguments.reference_source)))
