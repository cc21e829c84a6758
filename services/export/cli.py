"""`dogged export RUN --lerobot DIR --student FILE`: a recorded run as a LeRobot dataset and its student as a
file; `dogged snapshot learner FILE`: a running learner's student as a file."""
from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

from services.export.episodes import EPISODE_BY
from services.export.ticks import ExportError


def export_main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="dogged export", description=__doc__.splitlines()[0])
    parser.add_argument("run", help="a recorder's folder (runs/<profile>/recordings/<when>) or one .mcap file")
    parser.add_argument("--lerobot", metavar="DIR", help="write a LeRobot dataset (v3.0) into this new folder")
    parser.add_argument("--student", metavar="FILE", help="write the taught student into this file, replacing it "
                                                          "(load it with services.learners.load_student)")
    parser.add_argument("--instance", default="main")
    parser.add_argument("--episode-by", default="auto", choices=EPISODE_BY,
                        help="where episodes begin (always at a platform restart): the Gymnasium platform's "
                             "episodes, the arena's resets, teaching spans, or restarts only (default auto: gym, "
                             "else arena, else run)")
    parser.add_argument("--no-video", action="store_true", help="leave the camera out")
    parser.add_argument("--fps", type=int, default=None, help="the dataset's rate (default: the recorded one)")
    parser.add_argument("--live", default=None, metavar="LEARNER", help="whose student (default: the only one)")
    parser.add_argument("--learner", default=None, metavar="SPEC",
                        help="the student's learner, e.g. 'lwpr:init_D=2' (default: the live one's, from its status)")
    parser.add_argument("--seed", type=int, default=0, help="the student's seed (the learner box's default: 0)")
    args = parser.parse_args(argv)
    if not (args.lerobot or args.student):
        parser.error("nothing to do: give --lerobot DIR and/or --student FILE")
    if args.fps is not None and not 1 <= args.fps <= 1000:
        parser.error(f"--fps must be in 1..1000, got {args.fps}")
    try:
        if args.lerobot:
            export_dataset(args)
        if args.student:
            export_student_file(args)
    except (ExportError, OSError) as err:
        print(f"dogged export: {err}", file=sys.stderr)
        return 2
    return 0


def export_dataset(args) -> None:
    from services.export.lerobot import export_lerobot, needs_export_extra
    from services.export.ticks import read_ticks
    needs_export_extra()
    out = Path(args.lerobot)
    if out.exists():  # before the run is read
        raise ExportError(f"{out}: already exists; give a new folder (nothing is overwritten)")
    start = time.perf_counter()
    table = read_ticks(args.run, args.instance, camera=not args.no_video)
    done = export_lerobot(args.run, table, out, args.episode_by, not args.no_video, args.fps)
    took = time.perf_counter() - start
    camera = "with the camera" if done["video"] else "no camera" + (" recorded" if not args.no_video else "")
    episodes = f"{done['episodes']} episode" + ("s" if done["episodes"] != 1 else "")
    print(f"{out}: {done['frames']} frames in {episodes} (by {done['episode_by']}) at "
          f"{done['fps']} fps, {camera}; {table.duration_s:.0f} s recorded, exported in {took:.1f} s"
          + (f"; {done['left_out']} inputs had no command recorded and were left out" if done["left_out"] else ""))


def export_student_file(args) -> None:
    from services.export.student import export_student
    from services.recording.runs import load_run
    try:
        run = load_run(args.run, args.instance)
    except (ValueError, FileNotFoundError) as err:
        raise ExportError(str(err)) from None
    if not len(run.pair_x):
        raise ExportError(f"{args.run}: no training pairs recorded: nothing was taught")
    try:
        model = export_student(args.run, run, Path(args.student), args.live, args.learner, args.seed)
    except (KeyError, ValueError) as err:  # an unknown learner or hyper-parameter in --learner
        raise ExportError(str(err).strip("'\"")) from None
    print(f"{args.student}: a {type(model).__name__} student, {model.n_learned} pairs learned")
    if fits_on_their_own_thread(model):
        print(f"note: live, a {type(model).__name__} fits on its own thread, so what it answered also depended on "
              "when each fit landed: this is the same learner taught the same pairs offline, not the live one's "
              "state; `dogged snapshot learner FILE` takes that from a running learner", file=sys.stderr)


def fits_on_their_own_thread(model) -> bool:
    """Whether a learner served live moves its upkeep (the GP's fits) off the loop's thread."""
    from services.learners import Learner, PerOutput
    if isinstance(model, PerOutput):
        return any(fits_on_their_own_thread(part) for part in model._parts)
    return type(model).serve_live is not Learner.serve_live


def snapshot_main(argv: list[str]) -> int:
    """`dogged snapshot learner FILE`: the running learner's state and the platform's spaces, as a file."""
    from services.cli import global_flags
    parser = argparse.ArgumentParser(prog="dogged snapshot", parents=[global_flags()],
                                     description="Write a running learner's student into a file.")
    parser.add_argument("what", choices=["learner"])
    parser.add_argument("file", help="the student file (load it with services.learners.load_student)")
    parser.add_argument("--name", default="learner", help="which learner service (default: learner)")
    parser.add_argument("--instance", default="main")
    args = parser.parse_args(argv)
    from services.bus.config import use_certificate
    use_certificate(args)
    try:
        said = snapshot_learner(args)
    except (ExportError, OSError) as err:
        print(f"dogged snapshot: {err}", file=sys.stderr)
        return 1
    print(said)
    return 0


def snapshot_learner(args) -> str:
    from bus_schema import InstanceKeys, SchemaError, Snapshot, decode
    from services.bus.queries import ask_owner, fetch_spaces
    from services.learners import LEARNERS, save_student
    from services.learners.base import SnapshotError
    from services.supervisor.commands import _session
    keys = InstanceKeys(args.instance)
    with _session(args) as session:
        payload, problem = ask_owner(session, keys.snapshot(args.name), 30.0)
        if payload is None:
            raise ExportError(f"learner {args.name} of dl/{args.instance} gave no snapshot: {problem}")
        spaces = fetch_spaces(session, keys.spaces, False, logging.getLogger("dogged snapshot"), timeout=10.0)
    if spaces is None:
        raise ExportError(f"the platform of dl/{args.instance} did not say its spaces within 10 s")
    try:
        snap = decode(Snapshot, payload, keys.snapshot(args.name))
        cls = {c.__name__: c for c in LEARNERS.values()}.get(snap.learner_class)
        if cls is None:
            raise ExportError(f"learner {args.name} is a {snap.learner_class}, not a registered learner")
        model = cls.restore(snap.blob)
    except (SchemaError, SnapshotError) as err:
        raise ExportError(f"learner {args.name}'s snapshot was refused: {err}") from None
    origin = (f"dogged snapshot: learner {args.name} of dl/{args.instance}, {snap.n_learned} pairs, up to seq "
              f"{snap.seq} of epoch {snap.epoch}")
    save_student(args.file, model, spaces, origin)
    return f"{args.file}: a {snap.learner_class} student, {model.n_learned} pairs learned (up to seq {snap.seq})"

