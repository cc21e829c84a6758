"""Record a mirroring run and a ball-seeking run with the recorder, replay them, compare learners (issue 14).

    .venv/bin/python benchmarks/replay.py [--quick]

Mirroring: the Aibo at 30 Hz of wall time (as deployed), the handler, the mirror teacher, a live LWPR learner,
under the supervisor; taught, then the student alone; last the recorder is SIGKILLed and the seconds its
file lost before the kill are measured. Ball seeking: the demo's protocol over the bus (camera at 15 Hz
recorded), the wired GP learner.
Each recording is replayed with three learners, answering each input on the live learner's schedule
and measured against the teacher program run on every input (the paper's Figure 5 measure). The
replay speed-up is the recorded duration over the time a replay with LWPR takes (relearning every
pair, answering every input; its kernels compiled before the clock starts, as the live learner's
are), and the same with the learner the profile wires (replay_speedup_wired: issue 34 asks 50x), side by side
in processes as `dogged replay` does where it is per-output (and in this process, the baseline:
replay_speedup_wired_one_process_mirroring).
Last line: one JSON object (replay_speedup, replay_speedup_wired, recorder_mb_per_min,
lost_after_sigkill_s, final_error_<run>_<learner>, ...).
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: services.*, rigs.*
import services  # noqa: E402,F401  (first: one BLAS thread per process, see services/__init__.py)

import argparse  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import signal  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from rigs.harness import free_port  # noqa: E402
from rigs.live.mirroring import start_mirroring  # noqa: E402
from services.demo.ballseek import run_ballseek_live  # noqa: E402
from services.experiments.wiring import wired_spec  # noqa: E402
from services.learners import compile_kernels, make_learner  # noqa: E402
from services.recording.reader import iter_samples, run_files  # noqa: E402
from services.recording.runs import load_run  # noqa: E402
from services.replay.cli import compare  # noqa: E402
from services.replay.compare import table  # noqa: E402
from services.replay.replay import learner_from_spec, replay, schedule  # noqa: E402
from services.replay.side_by_side import ReplayWorkers, output_bins, replay_side_by_side  # noqa: E402
from services.teachers import make_teacher  # noqa: E402
from services.waiting import poll  # noqa: E402

LEARNERS = {"mirroring": ("lwpr", "sogp", "knn"), "ballseek": ("lwpr", "gp", "knn")}
TEACHERS = {"mirroring": "mirror", "ballseek": "ballseek"}


def record_mirroring(work: Path, teach_s: float, student_s: float) -> tuple[Path, float]:
    """A recorded mirroring run (live LWPR) and the seconds its recorder's file lost to a SIGKILL."""
    # at 30 Hz of wall time, as deploy/mirroring.toml runs: a lockstep run's recording is its lesson squeezed into a
    # fifth of the time (1,801 pairs in 6 s), which no user records
    run = start_mirroring(work, f"tcp/127.0.0.1:{free_port()}", learner="lwpr", realtime=True)
    try:
        run.teach(True)
        run.run_ticks(int(teach_s * 30))
        run.teach(False)
        run.run_ticks(int(student_s * 30))
        pid = run.ps()["recorder"]["pid"]
        os.kill(pid, signal.SIGKILL)
        killed_ns = time.time_ns()
        restarted = poll(lambda: (r := run.ps().get("recorder")) and r["pid"] != pid and r["state"] == "ready", 30, 0.2)
        if not restarted:
            raise RuntimeError("the recorder did not come back after its SIGKILL")
    finally:
        run.close()
    [folder] = list((work / "recordings").iterdir())
    killed_file = run_files(folder)[0]  # repaired by the restarted recorder
    last_ns = max(s.log_ns for s in iter_samples(killed_file))
    return folder, (killed_ns - last_ns) / 1e9


def record_ballseek(work: Path, teach_s: float, episodes: int) -> Path:
    run_ballseek_live(work, f"tcp/127.0.0.1:{free_port()}", teach_seconds=teach_s, episodes=episodes,
                      orange_episodes=0, log=lambda line: print(line, file=sys.stderr))
    [folder] = list((work / "recordings").iterdir())
    return folder


def size_figures(folder: Path) -> dict:
    files = run_files(folder)
    times = [s.log_ns for s in iter_samples(folder)]
    minutes = (max(times) - min(times)) / 60e9
    mb = sum(p.stat().st_size for p in files) / 1e6
    return {"files": len(files), "messages": len(times), "mb": mb, "minutes": minutes, "mb_per_min": mb / minutes}


def replay_figures(name: str, folder: Path) -> dict:
    run = load_run(folder)
    live = next(iter(run.live))
    plan = schedule(run, live)
    compile_kernels(make_learner("lwpr", run.spaces.input.dims, run.spaces.output.dims))  # before the clock
    start = time.perf_counter()
    lwpr = replay(run, "lwpr", 0, plan)
    took = time.perf_counter() - start
    wired = wired_spec(name)  # the learner the profile wires (issue 34: 50x the recorded time)
    n_in, n_out = run.spaces.input.dims, run.spaces.output.dims
    compile_kernels(learner_from_spec(wired, n_in, n_out, 0))
    start = time.perf_counter()
    one = replay(run, wired, 0, plan)  # in this process: the baseline
    one_took = time.perf_counter() - start
    bins = output_bins(run, wired)  # as `dogged replay` does: a per-output learner side by side
    wired_took = one_took
    if bins:
        with ReplayWorkers(len(bins), wired, n_in, n_out) as workers:  # ready (kernels compiled) before the clock
            start = time.perf_counter()
            side_by_side = replay_side_by_side(run, wired, 0, plan, workers, bins)
            wired_took = time.perf_counter() - start
        if not (np.array_equal(side_by_side.y, one.y) and np.array_equal(side_by_side.confidence, one.confidence)):
            raise AssertionError(f"{name}: side by side, the wired learner answered otherwise than in one process")
    inputs, answers = run.answered(live)
    reproduced = float(np.max(np.abs(lwpr.y[inputs] - run.live[live].y[answers]))) if name == "mirroring" else None
    teacher = make_teacher(TEACHERS[name], run.spaces)
    rows = compare(run, list(LEARNERS[name]), teacher=teacher, live=live)
    print(f"\n{name}: {len(run.ticks)} inputs over {run.duration_s:.0f} s, {len(run.pair_ticks)} pairs; "
          f"reference: teacher {TEACHERS[name]} on every input")
    print(table(rows, 0.1))
    out = {"speedup": run.duration_s / took, "duration_s": run.duration_s, "replay_s": took, "wired": wired,
           "wired_s": wired_took, "wired_speedup": run.duration_s / wired_took, "wired_processes": len(bins) or 1,
           "wired_one_s": one_took, "wired_one_speedup": run.duration_s / one_took,
           "final": {r.spec: r.final_error for r in rows}, "student": {r.spec: r.student_error for r in rows}}
    if reproduced is not None:
        out["reproduced_max_abs"] = reproduced
    return out


def main(quick: bool, out: str | None = None) -> dict:
    began = time.monotonic()
    teach_s, student_s, episodes = (20.0, 10.0, 1) if quick else (60.0, 30.0, 3)
    with tempfile.TemporaryDirectory(prefix="dogged-replay-") as tmp:
        work = Path(out) if out else Path(tmp)
        mirroring, lost_s = record_mirroring(work / "mirroring", teach_s, student_s)
        ballseek = record_ballseek(work / "ballseek", 30.0 if quick else 60.0, episodes)
        sizes = {"mirroring": size_figures(mirroring), "ballseek": size_figures(ballseek)}
        replays = {name: replay_figures(name, folder) for name, folder in (("mirroring", mirroring),
                                                                            ("ballseek", ballseek))}
    print(f"\n{'recording':<12}{'minutes':>9}{'messages':>10}{'files':>7}{'MB':>8}{'MB/min':>8}"
          f"{'replay s':>10}{'speed-up (LWPR)':>17}{'wired learner':>24}{'processes':>11}{'replay s':>10}"
          f"{'speed-up':>10}{'in one: s':>11}{'speed-up':>10}")
    for name, s in sizes.items():
        r = replays[name]
        print(f"{name:<12}{s['minutes']:>9.2f}{s['messages']:>10}{s['files']:>7}{s['mb']:>8.1f}{s['mb_per_min']:>8.2f}"
              f"{r['replay_s']:>10.2f}{r['speedup']:>16.0f}x{r['wired']:>24}{r['wired_processes']:>11}"
              f"{r['wired_s']:>10.2f}{r['wired_speedup']:>9.1f}x{r['wired_one_s']:>11.2f}{r['wired_one_speedup']:>9.1f}x")
    print("wired learner: side by side, each output taught more than one value in a process of its own and the outputs "
          "held still in one more (started before the clock), answering to the last bit as in one process (checked); "
          "in one: the same replay in this process")
    print(f"SIGKILL of the recorder: its file lost the last {lost_s:.2f} s before the kill; replayed LWPR "
          f"matches the live one to {replays['mirroring']['reproduced_max_abs']:.1e} on every answer")
    figures = {"replay_speedup": round(min(r["speedup"] for r in replays.values()), 1),
               "replay_speedup_mirroring": round(replays["mirroring"]["speedup"], 1),
               "replay_speedup_ballseek": round(replays["ballseek"]["speedup"], 1),
               "replay_speedup_wired": round(min(r["wired_speedup"] for r in replays.values()), 1),
               "replay_speedup_wired_mirroring": round(replays["mirroring"]["wired_speedup"], 1),
               "replay_speedup_wired_ballseek": round(replays["ballseek"]["wired_speedup"], 1),
               "replay_speedup_wired_one_process_mirroring": round(replays["mirroring"]["wired_one_speedup"], 1),
               "replay_processes_wired_mirroring": replays["mirroring"]["wired_processes"],
               "recorder_mb_per_min": round(sizes["ballseek"]["mb_per_min"], 2),
               "recorder_mb_per_min_mirroring": round(sizes["mirroring"]["mb_per_min"], 2),
               "lost_after_sigkill_s": round(lost_s, 3),
               "replay_reproduced_max_abs": replays["mirroring"]["reproduced_max_abs"],
               "wall_s": round(time.monotonic() - began, 1)}
    for name, r in replays.items():
        for spec, value in r["final"].items():
            figures[f"final_error_{name}_{spec.replace(' ', '_')}"] = None if np.isnan(value) else round(value, 4)
    return figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter runs (a few minutes)")
    parser.add_argument("--out", default=None, help="keep the runs (and their recordings) in this folder")
    args = parser.parse_args()
    print(json.dumps(main(args.quick, args.out)))
