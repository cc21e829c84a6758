"""How fast a recording becomes a LeRobot dataset (issue 33): `dogged export --lerobot` of an hour-long
recording without video, and of a shorter one with the Aibo's camera.

    .venv/bin/python benchmarks/export.py [--quick]

The recordings are synthesized, not run live (an hour of a live loop is an hour): real MCAP files written by
the recorder's own writer (services.recording.writer.RunWriter), holding what a recorded gym profile holds at
50 ticks a second: every tick's input, the learner's and (while taught, the first 30 %) the teacher's
proposal, the command, the applied command, the reward and the training pair; every second each of four
services' status; an episode every 200 steps. The camera run adds 208x160 JPEG frames at 15 Hz (the
Aibo's camera as perception's input). Timed: reading the recording and writing the whole dataset, in this
process (the CLI's own functions), each run once. Last line: one JSON object (export_x_realtime, ...).
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: services.*
import services  # noqa: E402,F401  (first: one BLAS thread per process, see services/__init__.py)

import argparse  # noqa: E402
import json  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from bus_schema import (Applied, Command, Episode, Frame, Input, Proposal, Reward, Status,  # noqa: E402
                        TrainingPair, encode)
from bus_schema.spaces import Box, Spaces  # noqa: E402
from services.export.lerobot import export_lerobot  # noqa: E402
from services.export.ticks import read_ticks  # noqa: E402
from services.recording.writer import RunWriter  # noqa: E402

RATE_HZ, CAMERA_HZ, EPISODE_STEPS, TAUGHT_SHARE = 50, 15, 200, 0.3
SERVICES = ("platform/platform", "teacher/teacher", "learner/learner", "arbitrator/arbitrator")


def synthesize(folder: Path, seconds: float, rate: float, camera: bool) -> int:
    """A recording of `seconds` at `rate` ticks a second; returns the messages written."""
    spaces = Spaces(Box.uniform(3, -8.0, 8.0, "obs"), Box.uniform(1, -2.0, 2.0, "torque"),
                    {"platform": "gym", "env": "Pendulum-v1"})
    writer = RunWriter(folder, "recorder", 512 * 10**6, 30 * 60.0)
    writer.add_metadata("spaces dl/main", {"spaces": json.dumps(spaces.to_dict())})
    writer.add_metadata("run", {"instances": "main", "robots": "aibo" if camera else ""})
    rng = np.random.default_rng(0)
    ticks, seq, start = int(seconds * rate), 0, 1.7e9
    for tick in range(1, ticks + 1):
        stamp = start + tick / rate
        ns = int(stamp * 1e9)
        x = np.sin(tick * np.array([0.01, 0.013, 0.02])) * 5 + rng.normal(0, 0.01, 3)
        taught = tick < TAUGHT_SHARE * ticks
        y = np.tanh(x[:1])
        if camera:
            writer.write("robot/aibo/camera", Frame, encode(Frame(tick, stamp, tick / rate, 208, 160,
                                                                  camera_jpeg(tick))), ns - 10**6, ns - 10**6)
        writer.write("dl/main/input", Input, encode(Input(tick, stamp, x)), ns, ns)
        writer.write("dl/main/proposal/learner/learner", Proposal,
                     encode(Proposal(tick, "learner/learner", y * 0.9, 0.5, learned=seq)), ns + 1000, ns + 1000)
        if taught:
            writer.write("dl/main/proposal/teacher/teacher", Proposal,
                         encode(Proposal(tick, "teacher/teacher", y, 1.0)), ns + 2000, ns + 2000)
        mode, source = ("teacher", "teacher/teacher") if taught else ("student", "learner/learner")
        writer.write("dl/main/command", Command, encode(Command(tick, stamp, y, mode, source, 0.5)), ns + 3000,
                     ns + 3000)
        if taught:
            seq += 1
            writer.write("dl/main/train", TrainingPair, encode(TrainingPair("e", seq, tick, x, y, source)), ns + 4000,
                         ns + 4000)
        writer.write("dl/main/applied", Applied, encode(Applied(tick, y, False)), ns + 5000, ns + 5000)
        step, episode = (tick - 1) % EPISODE_STEPS + 1, (tick - 1) // EPISODE_STEPS
        writer.write("dl/main/reward", Reward, encode(Reward(tick, episode, step, -1.0, -step, step == EPISODE_STEPS)),
                     ns + 6000, ns + 6000)
        if step == EPISODE_STEPS:
            writer.write("dl/main/episode", Episode, encode(Episode(episode, step, -step, False, True, {mode: step},
                                                                    stamp)), ns + 7000, ns + 7000)
        if tick % int(rate) == 0:
            for member in SERVICES:
                role, name = member.split("/")
                writer.write(f"dl/main/status/{member}", Status,
                             encode(Status(role, name, 1, {"ticks": tick}, {})), ns + 8000, ns + 8000)
        writer.upkeep()
    writer.close()
    return writer.messages


def camera_jpeg(tick: int) -> bytes:
    """An arena-like frame: a floor, a horizon, a ball that moves."""
    image = np.full((160, 208, 3), (90, 110, 120), np.uint8)
    image[:70] = (200, 170, 140)
    cv2.circle(image, (int(104 + 80 * np.sin(tick / 40)), 100), 14, (180, 80, 230), -1)
    return cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 80])[1].tobytes()


def timed_export(folder: Path, out: Path, video: bool) -> tuple[float, dict, float]:
    """(seconds to read and write the dataset, what was written, seconds recorded)."""
    start = time.perf_counter()
    table = read_ticks(folder, camera=video)
    done = export_lerobot(folder, table, out, "auto", video, fps=None)
    return time.perf_counter() - start, done, table.duration_s


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5 minutes without video, 1 with (a minute or so)")
    args = parser.parse_args()
    runs = (("no video", 300.0 if args.quick else 3600.0, RATE_HZ, False),
            ("camera", 60.0 if args.quick else 600.0, CAMERA_HZ, True))
    rows, figures = [], {}
    with tempfile.TemporaryDirectory(prefix="export-bench-") as work:
        for name, seconds, rate, camera in runs:
            folder = Path(work) / name.replace(" ", "-")
            start = time.perf_counter()
            messages = synthesize(folder, seconds, rate, camera)
            written_s = time.perf_counter() - start
            mb = sum(p.stat().st_size for p in folder.glob("*.mcap")) / 1e6
            took, done, recorded = timed_export(folder, Path(work) / f"{folder.name}-ds", camera)
            rows.append((name, recorded, messages, mb, written_s, done["frames"], done["episodes"], took,
                         recorded / took))
            key = "export_x_realtime" if not camera else "export_video_x_realtime"
            figures[key] = round(recorded / took, 1)
            figures[f"{key.rsplit('_x_', 1)[0]}_s"] = round(took, 2)
            figures["recorded_s" if not camera else "video_recorded_s"] = round(recorded)
    print(f"{'run':<10}{'recorded s':>11}{'messages':>10}{'MB':>7}{'synth s':>9}{'frames':>9}{'episodes':>9}"
          f"{'export s':>10}{'x real time':>13}")
    for name, recorded, messages, mb, written_s, frames, episodes, took, speed in rows:
        print(f"{name:<10}{recorded:>11.0f}{messages:>10}{mb:>7.1f}{written_s:>9.1f}{frames:>9}{episodes:>9}"
              f"{took:>10.2f}{speed:>13.1f}")
    print("export s: reading the MCAP recording and writing the whole LeRobot dataset (Parquet, metadata; the "
          "camera's H.264 MP4 in the camera run), one process; the recordings are synthesized with the recorder's "
          "writer, not recorded live")
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
