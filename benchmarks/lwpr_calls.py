"""LWPR's cost per call at the deploy profiles' shapes (issue 32), in one process, no bus.

    PYTHONPATH=. .venv/bin/python benchmarks/lwpr_calls.py [--turns 9]

Per shape (the point platform at dims=2, and benchmarks/lib/learner_costs.SHAPES): a model warmed on 3,000
samples of a smooth map streamed like a robot's joints answers then learns each of the next 300 samples,
as the learner box does (predict_one, learn_one: the median call); learn_many and predict_many per row
(the 3,000 samples from a fresh model; the warm model on all 3,300 inputs; CPU time). Microseconds;
each figure the fastest of `turns` turns, every turn from a copy of the same warm model, so a slow
spell of a shared machine shows as a slower turn, not a slower figure. Prints a table; the last line
is one JSON object of the figures.
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: benchmarks.*
import services  # noqa: E402  (first: one BLAS thread per process, see services/__init__.py)

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks.lib.learner_costs import SHAPES, smooth_map  # noqa: E402
from services.learners import compile_kernels, make_learner  # noqa: E402

WARM, CALLS = 3000, 300
# (label, n_in, n_out, outputs taught)
LWPR_SHAPES = (("point", 4, 2, 2),) + tuple((label, n_in, n_out, taught)
                                            for label, _, _, n_in, n_out, taught in SHAPES)


def per_call(model, xs: np.ndarray, ys: np.ndarray) -> tuple[float, float]:
    """Median microseconds of predict_one and of learn_one, answering then learning each sample in turn."""
    predict, learn, clock = np.empty(len(xs)), np.empty(len(xs)), time.perf_counter_ns
    for i, (x, y) in enumerate(zip(xs, ys)):
        started = clock()
        model.predict_one(x)
        between = clock()
        model.learn_one(x, y)
        predict[i], learn[i] = between - started, clock() - between
    return float(np.median(predict)) / 1e3, float(np.median(learn)) / 1e3


def per_row(work, rows: int) -> float:
    """Microseconds of this thread's CPU time per row: a batch runs long enough to be preempted on a busy
    machine, and waiting for a core is not its cost."""
    started = time.thread_time_ns()
    work()
    return (time.thread_time_ns() - started) / 1e3 / rows


def measure(label: str, n_in: int, n_out: int, taught: int, turns: int) -> dict[str, float]:
    xs, ys = smooth_map(n_in, n_out, taught, WARM + CALLS)
    lesson, after = (xs[:WARM], ys[:WARM]), (xs[WARM:], ys[WARM:])
    warm = make_learner("lwpr", n_in, n_out)
    compile_kernels(warm)
    warm.learn_many(*lesson)
    snapshot = warm.snapshot()
    best = {"predict_one_us": np.inf, "learn_one_us": np.inf, "learn_many_row_us": np.inf,
            "predict_many_row_us": np.inf}
    for _ in range(turns):  # the ways of calling take turns, so that a slow spell hits them all
        predict, learn = per_call(type(warm).restore(snapshot), *after)
        fresh = make_learner("lwpr", n_in, n_out)
        batch = per_row(lambda fresh=fresh: fresh.learn_many(*lesson), WARM)
        many = per_row(lambda: warm.predict_many(xs), len(xs))
        for key, value in zip(best, (predict, learn, batch, many)):
            best[key] = min(best[key], value)
    best["fields"] = warm.size
    return {f"lwpr_{label}_{key}": round(value, 3) for key, value in best.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--turns", type=int, default=9)
    args = parser.parse_args()
    print(f"LWPR per call, code from {Path(services.__file__).parents[1]}; microseconds, fastest of {args.turns} turns")
    print(f"{'shape':<18}{'fields':>7}{'predict_one':>13}{'learn_one':>11}{'learn_many/row':>16}{'predict_many/row':>18}")
    figures = {}
    for label, n_in, n_out, taught in LWPR_SHAPES:
        f = measure(label, n_in, n_out, taught, args.turns)
        figures |= f
        key = f"lwpr_{label}_"
        print(f"{f'{label} {n_in}->{n_out}':<18}{f[key + 'fields']:>7.0f}{f[key + 'predict_one_us']:>13.2f}"
              f"{f[key + 'learn_one_us']:>11.2f}{f[key + 'learn_many_row_us']:>16.2f}"
              f"{f[key + 'predict_many_row_us']:>18.2f}")
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
