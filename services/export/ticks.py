"""A recorded run as one row per tick for export: the platform's input, the command of that tick (output,
mode, source, confidence), the task's reward where the platform reports one, and where the run says an
episode ends (arena resets, Gymnasium episodes). Read in one pass over the recording, decoding only the
keys an export uses; camera frames are only located here (their JPEGs are read again when encoded)."""
from __future__ import annotations

import bisect
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bus_schema import ArenaReset, Clock, Command, Frame, Input, InstanceKeys, Reward, RobotKeys, SchemaError, Spaces
from bus_schema.codec import decode
from services.recording.reader import iter_samples, read_metadata, spaces_in
from services.recording.restarts import MATCH_S, PlatformRuns


class ExportError(ValueError):
    """A run that cannot be exported as asked, saying what is wrong."""


@dataclass
class Camera:
    """A robot's camera frames in the recording, in the order received: per frame, when it came and its own
    tick. Frames that do not decode, or whose size is not the first frame's, are not counted (one video)."""
    key: str
    log_ns: list = field(default_factory=list)
    ticks: list = field(default_factory=list)
    size: tuple[int, int] = (0, 0)  # (width, height) of the first frame

    def take(self, sample) -> Frame | None:
        """The sample's frame if it counts (then noted), else None; the same samples count on every read."""
        try:
            frame = decode(Frame, sample.raw, sample.key)
        except SchemaError:
            return None
        if not self.log_ns:
            self.size = (frame.width, frame.height)
        elif (frame.width, frame.height) != self.size:
            return None
        self.log_ns.append(sample.log_ns)
        self.ticks.append(frame.tick)
        return frame

    def frame_for(self, tick: int, log_ns: int, by_tick: dict) -> int:
        """The frame an input shows: the frame of its very tick received nearest to it (the camera is the
        input), else the last frame received before it; -1 before the first frame."""
        same = [i for i in by_tick.get(tick, ()) if abs(self.log_ns[i] - log_ns) <= MATCH_S * 1e9]
        if same:
            return min(same, key=lambda i: abs(self.log_ns[i] - log_ns))
        return bisect.bisect_right(self.log_ns, log_ns) - 1


@dataclass
class TickTable:
    """One row per recorded input that has a recorded command, in the order received."""
    instance: str
    spaces: Spaces
    robot: str                # the robot whose streams were recorded beside the instance ('' if none)
    runs: np.ndarray          # (n,) the platform's run (a restarted platform begins another)
    ticks: np.ndarray         # (n,)
    log_ns: np.ndarray        # (n,) when the recorder received the input
    stamps: np.ndarray        # (n,) the platform's stamp of the input (s)
    x: np.ndarray             # (n, n_in)
    y: np.ndarray             # (n, n_out) the command
    modes: np.ndarray         # (n,) teacher / student / unsure
    sources: np.ndarray       # (n,) who decided: teacher/<name>, learner/<name>, ...
    confidence: np.ndarray    # (n,)
    reward: np.ndarray | None = None    # (n,) the step's reward (gym), NaN where none was recorded
    done: np.ndarray | None = None      # (n,) whether the step ended its episode
    gym_episode: np.ndarray | None = None  # (n,) the platform's episode number, -1 where none was recorded
    arena_resets: list = field(default_factory=list)  # log_ns of each arena reset
    camera: Camera | None = None
    frames: np.ndarray | None = None    # (n,) the camera frame each row shows (index into camera), -1 none
    sim_times: np.ndarray | None = None  # (n,) the robot's simulated time at each row (its clock), if recorded
    left_out: int = 0                   # inputs with no command recorded (not rows)

    def __len__(self) -> int:
        return len(self.ticks)

    @property
    def duration_s(self) -> float:
        return float(self.stamps.max() - self.stamps.min()) if len(self.stamps) > 1 else 0.0


def recorded_robot(metadata: dict) -> str:
    robots = [r for r in metadata.get("run", {}).get("robots", "").split(",") if r]
    return robots[0] if robots else ""


def read_ticks(run: str | Path, instance: str = "main", robot: str | None = None,
               camera: bool = True) -> TickTable:
    """The run's rows for `instance`; `robot` (default: the one recorded) gives the arena resets and, with
    `camera`, the frames. ExportError says what is missing."""
    run = Path(run)
    if not run.exists():
        raise ExportError(f"{run}: no such recording (a recorder's folder, e.g. runs/<profile>/recordings/<when>, "
                          "or one .mcap file)")
    try:
        metadata = read_metadata(run)
    except FileNotFoundError as err:
        raise ExportError(str(err)) from None
    found = spaces_in(metadata, instance)
    if found is None:
        raise ExportError(f"{run}: no spaces of instance {instance!r} recorded (was its platform up? "
                          f"instances recorded: {metadata.get('run', {}).get('instances') or 'none said'})")
    spaces = Spaces.from_dict(found)
    robot = recorded_robot(metadata) if robot is None else robot
    reader = _Reader(InstanceKeys(instance), RobotKeys(robot) if robot else None, camera)
    reader.read(run)
    if not reader.inputs:
        raise ExportError(f"{run}: no ticks of instance {instance!r} recorded (no input on dl/{instance}/input)")
    return reader.table(instance, spaces, robot)


class _Reader:
    """One pass over the samples, in the order received."""

    def __init__(self, keys: InstanceKeys, robot_keys: RobotKeys | None, camera: bool):
        self.keys, self.robot_keys = keys, robot_keys
        self.runs = PlatformRuns()
        self.inputs: list = []    # (run, log_ns, Input)
        self.commands: dict = {}  # (run, tick) -> Command
        self.rewards: dict = {}   # (run, tick) -> Reward
        self.resets: list = []
        self.clock: list = []     # (log_ns, sim_time) of the robot's clock
        self.camera = Camera(robot_keys.camera) if robot_keys and camera else None
        self.wanted = {keys.input: Input, keys.command: Command, keys.reward: Reward}
        if robot_keys:
            self.wanted.update({robot_keys.arena: ArenaReset, robot_keys.clock: Clock})

    def read(self, run: Path) -> None:
        camera_key = self.camera.key if self.camera else None
        for sample in iter_samples(run, {*self.wanted, camera_key}):
            if sample.key == camera_key:
                self.camera.take(sample)
                continue
            cls = self.wanted.get(sample.key)
            if cls is None:
                continue
            try:
                msg = decode(cls, sample.raw, sample.key)
            except SchemaError:
                continue  # (this recorder writes none; a repaired file's could be anything)
            if cls is Input:
                self.inputs.append((self.runs.add_input(msg.tick, sample.log_ns), sample.log_ns, msg))
            elif cls is ArenaReset:
                self.resets.append(sample.log_ns)
            elif cls is Clock:
                self.clock.append((sample.log_ns, msg.sim_time))
            else:
                table = self.commands if cls is Command else self.rewards
                table[(self.runs.run_of(msg.tick, sample.log_ns, self.runs.current), msg.tick)] = msg

    def table(self, instance: str, spaces: Spaces, robot: str) -> TickTable:
        rows = [(at, ns, msg, self.commands.get((at, msg.tick))) for at, ns, msg in self.inputs]
        kept = [r for r in rows if r[3] is not None]
        if not kept:
            raise ExportError(f"instance {instance!r}: {len(rows)} inputs recorded but no command for any of them "
                              "(was the arbitrator up?)")
        n_out = spaces.output.dims
        table = TickTable(
            instance, spaces, robot, np.array([r[0] for r in kept], dtype=np.int64),
            np.array([r[2].tick for r in kept], dtype=np.int64), np.array([r[1] for r in kept], dtype=np.int64),
            np.array([r[2].stamp for r in kept]), np.array([r[2].x for r in kept]).reshape(len(kept), -1),
            np.array([r[3].y for r in kept]).reshape(len(kept), n_out), np.array([r[3].mode for r in kept]),
            np.array([r[3].source for r in kept]), np.array([r[3].confidence for r in kept]),
            arena_resets=sorted(self.resets), left_out=len(rows) - len(kept))
        if self.rewards:
            found = [self.rewards.get((at, msg.tick)) for at, _, msg, _ in kept]
            table.reward = np.array([np.nan if r is None else r.reward for r in found])
            table.done = np.array([r is not None and r.done for r in found])
            table.gym_episode = np.array([-1 if r is None else r.episode for r in found], dtype=np.int64)
        if self.clock:  # the clock received nearest each input
            clock_ns, sim = np.array(self.clock).T
            after = np.searchsorted(clock_ns, table.log_ns).clip(1, len(clock_ns) - 1)
            nearer = np.abs(clock_ns[after - 1] - table.log_ns) <= np.abs(clock_ns[after] - table.log_ns)
            table.sim_times = sim[np.where(nearer | (len(clock_ns) == 1), after - 1, after)]
        if self.camera and self.camera.log_ns:
            by_tick: dict = {}
            for i, tick in enumerate(self.camera.ticks):
                by_tick.setdefault(tick, []).append(i)
            frames = np.array([self.camera.frame_for(int(t), int(ns), by_tick)
                               for t, ns in zip(table.ticks, table.log_ns)], dtype=np.int64)
            table.camera, table.frames = self.camera, np.maximum.accumulate(frames)  # a video runs forward
        return table
