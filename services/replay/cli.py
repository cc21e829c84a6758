"""`dogged replay RUN --learner SPEC ...`: retrain learners on a recorded run and compare them; `dogged play
RUN`: publish its inputs into a live bus."""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from services.params import parse_params
from services.recording.runs import NoInputs, RecordedRun, load_run
from services.replay.compare import Figures, figures, plot, reference, table
from services.replay.replay import Replayed, as_served, catching_up, learner_from_spec, schedule
from services.replay.side_by_side import replay_any


def live_rows(run: RecordedRun) -> list[Replayed]:
    """Each live learner's recorded answers, as a replay would give them (NaN where it did not answer)."""
    rows = []
    for name, answers in sorted(run.live.items()):
        y, confidence = np.full((len(run.ticks), run.spaces.output.dims), np.nan), np.zeros(len(run.ticks))
        inputs, answered = run.answered(name)
        y[inputs], confidence[inputs] = answers.y[answered], answers.confidence[answered]
        rows.append(Replayed(f"live {name}", y, confidence, 0.0, 0.0, 0, 0))
    return rows


def compare(run: RecordedRun, specs: list[str], seed: int = 0, teacher=None, threshold: float = 0.1,
            quasi_batch: bool = False, live: str | None = None, progress: bool = False) -> list[Figures]:
    """Every spec replayed (answering on the live learner `live`'s schedule, unsure where it answered so while it
    caught up, else the default one) and its figures, after the live learners' own."""
    from tqdm import tqdm
    plan, unsure = schedule(run, live), catching_up(run, live)
    ref = reference(run, teacher)
    rows = [figures(run, r, ref, threshold) for r in live_rows(run)]
    with tqdm(total=len(specs) * len(run.ticks), unit="input", disable=not progress, file=sys.stderr) as bar:
        for spec in specs:
            result = as_served(replay_any(run, spec, seed, plan, quasi_batch, bar.update), unsure)
            rows.append(figures(run, result, ref, threshold))
    return rows


def replay_main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="dogged replay", description=__doc__.splitlines()[0])
    parser.add_argument("run", help="a recorder's folder (runs/<profile>/recordings/<when>) or one .mcap file")
    parser.add_argument("--learner", action="append", default=None, metavar="SPEC",
                        help="a learner to retrain, e.g. lwpr, sogp or 'lwpr:init_D=2' (repeatable; default lwpr)")
    parser.add_argument("--instance", default="main")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--teacher", default=None, help="the teacher program: run on every input as the reference "
                                                        "(default: the teacher's recorded outputs, where it spoke)")
    parser.add_argument("--teacher-param", action="append", default=None, metavar="NAME=VALUE")
    parser.add_argument("--threshold", type=float, default=0.1, help="error counted as reached / as wrong")
    parser.add_argument("--quasi-batch", action="store_true",
                        help="refit each learner from scratch at the end of every teaching span, not online")
    parser.add_argument("--live", default=None, metavar="LEARNER",
                        help="answer on this live learner's schedule (default: the only one recorded)")
    parser.add_argument("--plot", default=None, help="where the plot goes (default: compare.png beside the run)")
    parser.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = parser.parse_args(argv)
    specs = args.learner or ["lwpr"]
    try:
        run = load_run(args.run, args.instance)
        for spec in specs:
            learner_from_spec(spec, run.spaces.input.dims, run.spaces.output.dims, args.seed)  # refused before work
        teacher = None
        if args.teacher:
            from services.teachers import make_teacher
            teacher = make_teacher(args.teacher, run.spaces, **parse_params(args.teacher_param))
    except NoInputs as err:  # read, and found empty: no learner has anything to answer
        print(f"{err}: nothing to replay")
        return 0
    except (OSError, ValueError, KeyError) as err:
        print(f"dogged replay: {err}", file=sys.stderr)
        return 2
    live = args.live or (next(iter(run.live)) if len(run.live) == 1 else None)
    print(f"{args.run}: {len(run.ticks)} inputs over {run.duration_s:.1f} s, {len(run.pair_ticks)} training pairs, "
          f"live learners: {', '.join(sorted(run.live)) or 'none'}" + (f"; {len(run.truncated)} file(s) cut off"
                                                                       if run.truncated else ""))
    start = time.perf_counter()
    rows = compare(run, specs, args.seed, teacher, args.threshold, args.quasi_batch, live, progress=True)
    took = time.perf_counter() - start
    print(table(rows, args.threshold))
    reference_name = f"teacher {args.teacher} on every input" if teacher else "the teacher's recorded outputs"
    print(f"error: RMS over outputs of (reference - learner) / half the output range; reference: {reference_name}; "
          f"replayed in {took:.1f} s ({run.duration_s / took if took else float('inf'):.0f}x the recorded time)")
    run_dir = Path(args.run) if Path(args.run).is_dir() else Path(args.run).parent
    path = plot(Path(args.plot) if args.plot else run_dir / "compare.png", run, rows,
                f"{len(specs)} learners on {Path(args.run).name}")
    print(f"plot: {path}")
    if args.json:
        Path(args.json).write_text(json.dumps([f.row() for f in rows]))
    return 0


def play_main(argv: list[str]) -> int:
    """`dogged play RUN`: the run's inputs published in place of the platform, at the recorded rate times
    --speed (the platform box with the recorded platform: spaces, start-up wait, status as any platform)."""
    from services.bus.config import add_certificate_args
    parser = argparse.ArgumentParser(prog="dogged play",
                                     description="Publish a recorded run's inputs in place of the platform.")
    parser.add_argument("run", help="a recorder's folder or one .mcap file")
    parser.add_argument("--instance", default="main", help="whose inputs are played, and into which")
    parser.add_argument("--speed", type=float, default=1.0, help="times the recorded rate (e.g. 4)")
    parser.add_argument("--loop", action="store_true", help="start again at the end (default: stop)")
    parser.add_argument("--name", default="player")
    parser.add_argument("--connect", default=None, help="router endpoint (default $DOGGED_CONNECT or the local one)")
    add_certificate_args(parser)
    args = parser.parse_args(argv)
    from services.recording.platform import RecordedPlatform
    try:
        recorded = RecordedPlatform(args.run, args.instance, args.loop)
    except (OSError, ValueError) as err:
        print(f"dogged play: {err}", file=sys.stderr)
        return 2
    if not 0 < args.speed <= 1000:
        print("dogged play: --speed must be in (0, 1000]", file=sys.stderr)
        return 2
    rate = recorded.recorded_hz * args.speed
    print(f"playing {len(recorded)} inputs of {args.instance} at {rate:.1f} Hz ({args.speed:g}x)", file=sys.stderr)
    from services.boxes import platform
    box_args = ["--instance", args.instance, "--name", args.name, "--platform", "recorded",
                "--param", f"run={json.dumps(str(args.run))}", "--param", f"instance={json.dumps(args.instance)}",
                "--param", f"loop={json.dumps(args.loop)}", "--rate", f"{rate:.6g}"]
    if not args.loop:
        box_args += ["--max-ticks", str(len(recorded))]
    for flag, value in (("--connect", args.connect), ("--security", args.cert_dir), ("--identity", args.cert_identity)):
        if value:  # the bus flags, handed on
            box_args += [flag, value]
    return platform.cli(box_args)
