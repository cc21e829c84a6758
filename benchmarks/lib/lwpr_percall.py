"""Where one LWPR call's time goes (issue 17): the Python method, numba's dispatch of the kernel's
arguments, and the compiled kernel itself; the exact fit's share of an update; and, given the
reference library's checkout, its own update rates on the same streams, timed on this machine.

learn_one = wrapper + dispatch + kernel, measured as: the method; the kernel called through numba's
dispatcher with the method's arguments; an empty compiled function taking the same arguments
(dispatch alone); learn_many per row (the kernel with no per-call cost)."""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numba as nb
import numpy as np

from benchmarks.lib import lwpr_reference
from rigs.lwpr_draws import cross_case, mirror_case
from rigs.tasks import CROSS_LWPR_PARAMS
from services.learners import lwpr as lwpr_module
from services.learners import make_learner


@nb.njit
def _nothing8(a, b, c, d, e, f, g, h):
    return 0


@nb.njit
def _nothing9(a, b, c, d, e, f, g, h, i):
    return 0.0, False


def _us_per_item(work, count: int, repeats: int = 5, fresh=None) -> float:
    """Microseconds per item of the fastest of `repeats` runs (the least disturbed on a shared machine);
    `fresh()`, if given, is called before each run, off the clock, and its result handed to `work`."""
    best = float("inf")
    for _ in range(repeats):
        state = fresh() if fresh else None
        start = time.perf_counter()
        work(state) if fresh else work()
        best = min(best, time.perf_counter() - start)
    return best / count * 1e6


def per_call(count: int = 3000) -> dict[str, float]:
    """Microseconds per call on the tutorial cross (tutorial settings), each run on a fresh copy of one
    model warmed up on 5000 updates, so that every way of calling does the same work."""
    case = cross_case(0)
    xs, ys = case.xs[5000:5000 + count], case.ys[5000:5000 + count]
    warm = make_learner("lwpr", 2, 1, **CROSS_LWPR_PARAMS)
    warm.learn_many(case.xs[:5000], case.ys[:5000])
    kernels, snapshot = lwpr_module._kernels(), warm.snapshot()
    y, interval = np.empty(1), np.empty(1)

    def fresh():
        return type(warm).restore(snapshot)

    def learn_method(m):
        for x, t in zip(xs, ys):
            m.learn_one(x, t)

    def learn_with(function):
        def run(m):
            taught, shown = m._taught, m._shown
            for x, t in zip(xs, ys):
                function(m._model, x, t, x, taught.low, taught.high, shown.low, shown.high)
        return run

    def predict_method(m):
        for x in xs:
            m.predict_one(x)

    def predict_with(function):
        def run(m):
            taught, shown = m._taught, m._shown
            for x in xs:
                function(m._model, x, y, interval, taught.floor, taught.ceiling, x, shown.low, shown.high)
        return run

    model = fresh()  # numba compiles the empty functions for these argument types here, off the clock
    taught, shown = model._taught, model._shown
    _nothing8(model._model, xs[0], ys[0], xs[0], taught.low, taught.high, shown.low, shown.high)
    _nothing9(model._model, xs[0], y, interval, taught.floor, taught.ceiling, xs[0], shown.low, shown.high)
    runs = {
        "learn_one_us": learn_method,
        "learn_kernel_call_us": learn_with(kernels.learn_one),
        "learn_dispatch_us": learn_with(_nothing8),
        "learn_many_row_us": lambda m: m.learn_many(xs, ys),
        "predict_one_us": predict_method,
        "predict_kernel_call_us": predict_with(kernels.predict_one),
        "predict_dispatch_us": predict_with(_nothing9),
        "predict_many_row_us": lambda m: m.predict_many(xs),
    }
    figures = {key: float("inf") for key in runs}
    for _ in range(7):  # the ways of calling take turns, so that a slower spell of the machine hits them all
        for key, work in runs.items():
            figures[key] = min(figures[key], _us_per_item(work, count, repeats=1, fresh=fresh))
    figures["cross_rfs"] = warm.rfs_per_output[0]
    return figures


def rate_streams() -> dict:
    """The streams both libraries' update rates are measured on: task -> (case, our settings, the
    reference's settings). Mirroring 18 -> 18 with our defaults, 5000 updates; the cross with the
    tutorial's settings, 60 epochs."""
    return {"mirror": (mirror_case(0, samples=5000), {}, lwpr_reference.our_defaults(18)),
            "cross": (cross_case(0, epochs=60), CROSS_LWPR_PARAMS, lwpr_reference.TUTORIAL)}


def batch_rates() -> dict[str, float]:
    """Updates per second of learn_many from a fresh model, with and without the exact fit."""
    figures = {}
    for task, (case, params, _) in rate_streams().items():
        for label, exact in (("", True), ("_no_exact_fit", False)):
            def fresh(n=case.xs.shape[1], n_out=case.ys.shape[1], params=params, exact=exact):
                return make_learner("lwpr", n, n_out, **params, exact_fit=exact)
            us = _us_per_item(lambda m, case=case: m.learn_many(case.xs, case.ys), len(case.xs), repeats=2,
                              fresh=fresh)
            figures[f"fresh_{task}_updates_per_s{label}"] = 1e6 / us
    return figures


def reference_rates(source: Path) -> dict[str, float]:
    """The reference library's updates per second on rate_streams (its driver process timed whole, so a
    little under its update loop's own rate)."""
    figures = {}
    with tempfile.TemporaryDirectory() as work:
        binary = lwpr_reference.build(source, Path(work))
        for task, (case, _, settings) in rate_streams().items():
            def drive(case=case, settings=settings):
                lwpr_reference.run(binary, case, settings)
            figures[f"reference_{task}_updates_per_s"] = 1e6 / _us_per_item(drive, len(case.xs), repeats=3)
    return figures


def table(figures: dict) -> None:
    f = figures
    print("\nWhere one LWPR call's time goes (cross, tutorial settings, "
          f"{f['cross_rfs']} fields; microseconds, fastest of 7 turns):")
    print(f"  {'':12} {'whole call':>10} {'Python method':>13} {'numba dispatch':>14} {'compiled work':>13} "
          f"{'batch, per row':>14}")
    for call, batch in (("learn", "learn_many"), ("predict", "predict_many")):
        whole, kernel, dispatch = f[f"{call}_one_us"], f[f"{call}_kernel_call_us"], f[f"{call}_dispatch_us"]
        print(f"  {call + '_one':12} {whole:>10.2f} {whole - kernel:>13.2f} {dispatch:>14.2f} "
              f"{kernel - dispatch:>13.2f} {f[batch + '_row_us']:>14.2f}")
    print(f"  learn_many updates/s from a fresh model: cross {f['fresh_cross_updates_per_s']:,.0f} (without the "
          f"exact fit {f['fresh_cross_updates_per_s_no_exact_fit']:,.0f}), mirroring 18 -> 18 "
          f"{f['fresh_mirror_updates_per_s']:,.0f} ({f['fresh_mirror_updates_per_s_no_exact_fit']:,.0f})")
    if "reference_cross_updates_per_s" in f:
        print(f"  the reference library, same streams, this run: cross {f['reference_cross_updates_per_s']:,.0f}, "
              f"mirroring {f['reference_mirror_updates_per_s']:,.0f} updates/s")
