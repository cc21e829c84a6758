"""What one learner call costs at the shapes the deploy profiles wire (issue 34), in one process.

Each learner is warmed offline (learn_many) on 3,000 samples of a smooth random map streamed like a
robot's joints (services.learners.unknown_tasks at 30 Hz: 100 s of teaching), then answers and learns
the stream's next samples one at a time, as the learner service does (answer the input, then learn the
pair): offline, where a due fit runs inside learn_one, and served live (serve_live), where fits run on
the fitter's thread and learn_one's amortised time is what the service's answer path pays."""
from __future__ import annotations

import time

import numpy as np

from services.experiments.wiring import wired_learner
from services.learners import LEARNERS, compile_kernels, make_learner
from services.learners.unknown_tasks import draw_task

WARM_SAMPLES, RATE = 3000, 30.0
# (label, profile, instance, n_in, n_out, outputs taught): the dims are the profile's spaces (mirroring: the
# Aibo's 18 joints both ways, the mirror teacher teaching the head's pan and tilt and holding the rest at 0;
# ball seeking: perception's 2 blob slots of 5 -> forward, turn; the walk level: forward, turn and the gait
# clock's sin, cos -> 12 leg joints; gym: Pendulum-v1's cos, sin, rate -> torque)
SHAPES = (("mirroring", "mirroring", None, 18, 18, 2), ("ballseek", "ballseek", None, 10, 2, 2),
          ("walk", "hierarchy", "walk", 4, 12, 12), ("gym", "gym", None, 3, 1, 1))


def smooth_map(n_in: int, n_out: int, taught: int, samples: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """`samples` of a random smooth map of 2-4 inputs onto `taught` outputs (the rest held), in time order."""
    task = draw_task(seed, -np.ones(n_in), np.ones(n_in), -np.ones(n_out), np.ones(n_out), taught=(taught, taught))
    xs = task.stream(samples / RATE, RATE)
    return xs, task.target(xs)


def timed_calls(model, xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Milliseconds of each predict_one and each learn_one, answering then learning each sample in turn."""
    return timed_calls_cpu(model, xs, ys)[:2]


def timed_calls_cpu(model, xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """timed_calls, and the mean milliseconds of the caller's thread's own CPU time in learn_one: what the
    answer path spends, apart from waiting for the cores and the GIL (a shared 2-core machine at load 6-8
    made the wall time of the same calls 3-4x their CPU time)."""
    predict, learn, cpu = np.empty(len(xs)), np.empty(len(xs)), 0.0
    for i, (x, y) in enumerate(zip(xs, ys)):
        started = time.perf_counter()
        model.predict_one(x)
        between, cpu_before = time.perf_counter(), time.thread_time()
        model.learn_one(x, y)
        predict[i], learn[i] = between - started, time.perf_counter() - between
        cpu += time.thread_time() - cpu_before
    return predict * 1e3, learn * 1e3, cpu * 1e3 / max(len(xs), 1)


def settle(model, timeout: float = 120.0) -> None:
    """Wait (off the clock) until a live learner's fits are done."""
    end = time.monotonic() + timeout
    while model.upkeep_under_way and time.monotonic() < end:
        time.sleep(0.05)


def cost(name: str, params: dict, n_in: int, n_out: int, taught: int, calls: int, offline: bool) -> dict:
    """The lesson (WARM_SAMPLES) served live, back to back: what learn_one costs the answer path, fits on
    the fitter's thread; then, fits done, each call's cost to the warm learner; with `offline`, the lesson
    again with fits inside learn_one (what a learner fitting in the caller's thread would pay)."""
    xs, ys = smooth_map(n_in, n_out, taught, WARM_SAMPLES + calls)
    lesson, after = (xs[:WARM_SAMPLES], ys[:WARM_SAMPLES]), (xs[WARM_SAMPLES:], ys[WARM_SAMPLES:])
    compile_kernels(make_learner(name, n_in, n_out, **params))  # off the clock, as the service does
    model = make_learner(name, n_in, n_out, **params)
    model.serve_live()
    live_predict, live_learn, live_learn_cpu = timed_calls_cpu(model, *lesson)
    settle(model)
    predict, learn = timed_calls(model, *after)
    out = {"predict_ms": float(np.median(predict)), "predict_p99_ms": float(np.percentile(predict, 99)),
           "learn_ms": float(np.median(learn)), "predict_live_ms": float(np.mean(live_predict)),
           "learn_live_ms": float(np.mean(live_learn)), "learn_live_cpu_ms": live_learn_cpu,
           "answer_live_p99_ms": float(np.percentile(live_predict + live_learn, 99)), "learn_offline_ms": float("nan")}
    if offline:
        _, offline_learn = timed_calls(make_learner(name, n_in, n_out, **params), *lesson)
        out["learn_offline_ms"] = float(np.mean(offline_learn))
    return out


def cases() -> list[tuple[str, str, str, dict, tuple[int, int, int]]]:
    """(shape label, learner label, learner, params, (n_in, n_out, taught)): each profile's wired learner, then every
    registered learner at its defaults at the same shape."""
    out = []
    for label, profile, instance, *shape in SHAPES:
        wired, params = wired_learner(profile, instance)
        out.append((label, f"{wired}({','.join(f'{k}={v}' for k, v in params.items())})" if params else wired,
                    wired, params, tuple(shape)))
        out += [(label, name, name, {}, tuple(shape)) for name in sorted(LEARNERS) if (name, {}) != (wired, params)]
    return out


def measure(quick: bool) -> tuple[list[tuple], dict]:
    """Rows for a table and the JSON figures, learner_<shape>_<learner>[_wired]_<figure>_ms."""
    rows, figures = [], {}
    for label, shown, name, params, (n_in, n_out, taught) in cases():
        c = cost(name, params, n_in, n_out, taught, calls=200 if quick else 1000, offline=not quick)
        rows.append((f"{label} {n_in}->{n_out}", shown, c))
        key = f"learner_{label}_{name.replace('-', '_')}" + ("_wired" if params else "")
        figures |= {f"{key}_{figure}": round(value, 4) for figure, value in c.items()
                    if figure != "predict_p99_ms" and value == value}
    return rows, figures


def print_table(rows: list[tuple]) -> None:
    print(f"\n{'learner (ms per call)':<50}{'warm: predict':>14}{'p99':>8}{'learn':>8}"
          f"{'lesson live: predict':>22}{'learn':>8}{'cpu':>8}{'p99':>8}{'offline learn':>15}")
    for shape, shown, c in rows:
        print(f"{shape:<18}{shown:<32}{c['predict_ms']:>14.3f}{c['predict_p99_ms']:>8.3f}{c['learn_ms']:>8.3f}"
              f"{c['predict_live_ms']:>22.3f}{c['learn_live_ms']:>8.3f}{c['learn_live_cpu_ms']:>8.3f}"
              f"{c['answer_live_p99_ms']:>8.3f}{c['learn_offline_ms']:>15.3f}")
    print(f"warm: medians once taught {WARM_SAMPLES} samples of a smooth map (p99: a done fit applied in the call); "
          "lesson live: means over those samples served live, fits on the fitter's thread: what the service's "
          "answer path pays (cpu: learn's, the caller's thread's own; p99: predict + learn); offline: learn_one's "
          "mean over the lesson with fits inline (full runs only)")
