"""Every payload of the system. Units and channel semantics are in bus_schema/README.md."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .codec import BOOL, BYTES, FLOAT, INT, MAP, OPT_VECTOR, STR, VECTOR, VECTORS
from .errors import SchemaError
from .teachers import check_column, sources_of

MODES = ("teacher", "student", "unsure")


def _check_confidence(key: str, confidence: float) -> None:
    if not 0.0 <= confidence <= 1.0:
        raise SchemaError(key, "confidence", f"{confidence} is outside [0, 1]")


def _check_name(key: str, field: str, value: str, slashes: int = 0) -> None:
    if len(value) > 130 or value.count("/") > slashes or any(c in value for c in "*$?# "):
        shape = "a plain name" if not slashes else "'<role>/<name>'"
        raise SchemaError(key, field, f"{value!r} is not {shape} (no * $ ? # or space)")


@dataclass(frozen=True, slots=True)
class Input:
    """The platform's input for one tick. stamp: sender's wall clock, seconds."""
    FIELDS = (("tick", INT), ("stamp", FLOAT), ("x", VECTOR))
    tick: int
    stamp: float
    x: np.ndarray


@dataclass(frozen=True, slots=True)
class Proposal:
    """A teacher's or learner's answer to one input; y is None when a teacher has nothing to say.
    mask (0/1 per output, or None for all) marks the outputs a partial teacher speaks for. learned: how
    many training pairs a learner had learned when it answered (-1 from a teacher), so a recorded run's
    predictions can be reproduced (`dogged replay`); backlog: how many more it had taken in and not yet
    learned (it answers those ticks unsure, whatever its model says)."""
    FIELDS = (("tick", INT), ("source", STR), ("y", OPT_VECTOR), ("confidence", FLOAT), ("mask", OPT_VECTOR),
              ("learned", INT), ("backlog", INT))
    DEFAULTS = {"learned": -1, "backlog": 0}
    tick: int
    source: str
    y: np.ndarray | None
    confidence: float
    mask: np.ndarray | None = None
    learned: int = -1
    backlog: int = 0

    def check(self, key: str) -> None:
        _check_confidence(key, self.confidence)
        if self.learned < -1:
            raise SchemaError(key, "learned", f"{self.learned} pairs learned: -1 (a teacher) or a count")
        if self.backlog < 0:
            raise SchemaError(key, "backlog", f"{self.backlog} pairs yet to be learned: a count, at least 0")
        _check_name(key, "source", self.source, slashes=1)
        if self.mask is not None:
            if self.y is None or self.mask.shape != self.y.shape:
                raise SchemaError(key, "mask", "a mask needs an output y of the same length")
            if not np.all((self.mask == 0) | (self.mask == 1)):
                raise SchemaError(key, "mask", "mask values must be 0 or 1")


@dataclass(frozen=True, slots=True)
class Command:
    """The arbitrator's output for one tick, with the mode the robot shows (ears) and who chose it."""
    FIELDS = (("tick", INT), ("stamp", FLOAT), ("y", VECTOR), ("mode", STR), ("source", STR), ("confidence", FLOAT))
    tick: int
    stamp: float
    y: np.ndarray
    mode: str
    source: str
    confidence: float

    def check(self, key: str) -> None:
        if self.mode not in MODES:
            raise SchemaError(key, "mode", f"{self.mode!r} is not one of {', '.join(MODES)}")
        _check_confidence(key, self.confidence)


@dataclass(frozen=True, slots=True)
class TrainingPair:
    """One (input, output) pair for the learners. (epoch, seq) numbers pairs without gaps. mask (0/1
    per output, or None for all): the outputs a partial teacher taught; only those should be learned."""
    FIELDS = (("epoch", STR), ("seq", INT), ("tick", INT), ("x", VECTOR), ("y", VECTOR), ("source", STR),
              ("mask", OPT_VECTOR))
    epoch: str
    seq: int
    tick: int
    x: np.ndarray
    y: np.ndarray
    source: str
    mask: np.ndarray | None = None

    def check(self, key: str) -> None:
        if self.mask is not None and not np.all((self.mask == 0) | (self.mask == 1)):
            raise SchemaError(key, "mask", "mask values must be 0 or 1")


@dataclass(frozen=True, slots=True)
class PairBatch:
    """Many training pairs in one message (history, gap filling): rows of x, y and mask (the taught
    outputs, all 1 for a whole pair), seqs first..first+n-1; who taught each row (bus_schema.teachers:
    `teachers`, names one a line, and `teacher_of`, a byte per row), or nothing where not said."""
    FIELDS = (("epoch", STR), ("first_seq", INT), ("x", VECTORS), ("y", VECTORS), ("mask", VECTORS),
              ("teachers", STR), ("teacher_of", BYTES))
    DEFAULTS = {"teachers": "", "teacher_of": b""}
    MAX_BYTES = 256 * 1024 * 1024
    epoch: str
    first_seq: int
    x: np.ndarray
    y: np.ndarray
    mask: np.ndarray
    teachers: str = ""
    teacher_of: bytes = b""

    def check(self, key: str) -> None:
        if not len(self.x) == len(self.y) == len(self.mask):
            raise SchemaError(key, "y",
                              f"{len(self.y)} rows of y and {len(self.mask)} of mask for {len(self.x)} inputs")
        check_column(key, self.teachers, self.teacher_of, len(self.x))

    def sources(self) -> list[str] | None:
        """Each row's teacher, or None where the sender did not say."""
        return sources_of(self.teachers, self.teacher_of)


@dataclass(frozen=True, slots=True)
class Applied:
    """The command the platform actually applied (after clipping, or the held pose under the watchdog)."""
    FIELDS = (("tick", INT), ("y", VECTOR), ("held", BOOL))
    tick: int
    y: np.ndarray
    held: bool


@dataclass(frozen=True, slots=True)
class TeachSwitch:
    """A person switches a teacher on or off; teacher '' means every teacher of the instance."""
    FIELDS = (("teacher", STR), ("on", BOOL))
    teacher: str
    on: bool


@dataclass(frozen=True, slots=True)
class RecordSwitch:
    """A person pauses or resumes recording; recorder '' means every recorder of the instance."""
    FIELDS = (("recorder", STR), ("on", BOOL))
    recorder: str
    on: bool


@dataclass(frozen=True, slots=True)
class SelectLearner:
    """Tells the arbitrator which learner serves from now on (hot-swap)."""
    FIELDS = (("learner", STR),)
    learner: str

    def check(self, key: str) -> None:
        _check_name(key, "learner", self.learner)


@dataclass(frozen=True, slots=True)
class Status:
    """A service's counters and state, once a second, for `dogged ps` and dashboards."""
    FIELDS = (("role", STR), ("name", STR), ("pid", INT), ("counters", MAP), ("state", MAP))
    role: str
    name: str
    pid: int
    counters: dict
    state: dict

    def check(self, key: str) -> None:
        for name, value in self.counters.items():
            if not isinstance(name, str) or isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value):
                raise SchemaError(key, f"counters.{name}", "counters map names to finite numbers")


@dataclass(frozen=True, slots=True)
class SpacesMessage:
    """The platform's spaces as data (bus_schema.spaces.Spaces.to_dict)."""
    FIELDS = (("spaces", MAP),)
    spaces: dict


@dataclass(frozen=True, slots=True)
class Snapshot:
    """A learner's state for hot-swap: which class, and the last pair it includes."""
    FIELDS = (("learner_class", STR), ("epoch", STR), ("seq", INT), ("n_learned", INT), ("blob", BYTES))
    MAX_BYTES = 512 * 1024 * 1024
    learner_class: str
    epoch: str
    seq: int
    n_learned: int
    blob: bytes


@dataclass(frozen=True, slots=True)
class ControlReply:
    """The supervisor's answer to a CLI verb (ps, down, swap, logs): ok, a line for people, data."""
    FIELDS = (("ok", BOOL), ("text", STR), ("data", MAP))
    MAX_BYTES = 16 * 1024 * 1024
    ok: bool
    text: str
    data: dict


@dataclass(frozen=True, slots=True)
class Frame:
    """A JPEG camera frame. tick: the DL tick it starts when the camera is the input; beside
    another input, the frame's own count (perception may start another instance's ticks with it)."""
    FIELDS = (("tick", INT), ("stamp", FLOAT), ("sim_time", FLOAT), ("width", INT), ("height", INT), ("jpeg", BYTES))
    MAX_BYTES = 2 * 1024 * 1024
    tick: int
    stamp: float
    sim_time: float
    width: int
    height: int
    jpeg: bytes

    def check(self, key: str) -> None:
        if not (0 < self.width <= 4096 and 0 < self.height <= 4096):
            raise SchemaError(key, "width", f"{self.width}x{self.height} is not a plausible frame size")
        if self.jpeg[:2] != b"\xff\xd8":
            raise SchemaError(key, "jpeg", "not a JPEG (no FFD8 start-of-image marker)")


@dataclass(frozen=True, slots=True)
class Clock:
    """The simulation clock (s) beside the wall clock (s)."""
    FIELDS = (("sim_time", FLOAT), ("wall", FLOAT))
    sim_time: float
    wall: float


@dataclass(frozen=True, slots=True)
class Handle:
    """A person moves joints by hand: where mask is 1 the joint follows q, whatever else commands it."""
    FIELDS = (("mask", VECTOR), ("q", VECTOR))
    mask: np.ndarray
    q: np.ndarray

    def check(self, key: str) -> None:
        if self.mask.shape != self.q.shape:
            raise SchemaError(key, "q", f"{len(self.q)} positions for a mask of {len(self.mask)}")
        if not np.all((self.mask == 0) | (self.mask == 1)):
            raise SchemaError(key, "mask", "mask values must be 0 or 1")


@dataclass(frozen=True, slots=True)
class ArenaReset:
    """Rebuild the arena from a seed; balls maps a ball's name to [x, y] (m) or nil to hide it."""
    FIELDS = (("seed", INT), ("balls", MAP))
    seed: int
    balls: dict

    MAX_SEED, MAX_METRES, MAX_BALLS = 2 ** 32 - 1, 100.0, 16

    def check(self, key: str) -> None:
        if not 0 <= self.seed <= self.MAX_SEED:  # checked before anything is reset
            raise SchemaError(key, "seed", f"expected 0..{self.MAX_SEED}, got {self.seed}")
        if len(self.balls) > self.MAX_BALLS:
            raise SchemaError(key, "balls", f"at most {self.MAX_BALLS} balls, got {len(self.balls)}")
        for name, xy in self.balls.items():
            ok = xy is None or (isinstance(xy, list) and len(xy) == 2 and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                and abs(v) <= self.MAX_METRES for v in xy))
            if not isinstance(name, str) or not ok:
                raise SchemaError(key, f"balls.{name}", f"expected [x, y] within {self.MAX_METRES:g} m (finite) "
                                                        "or nil to hide")


@dataclass(frozen=True, slots=True)
class RobotState:
    """The simulator's ground truth, for judges and tools (never a DL input): base (x, y, yaw),
    nose (x, y, z), balls name -> [x, y, z] (m, rad), and the ears' mode and colour (RGBA 0-1)."""
    FIELDS = (("sim_time", FLOAT), ("base", VECTOR), ("nose", VECTOR), ("balls", MAP), ("ear_mode", STR),
              ("ear_rgba", VECTOR))
    sim_time: float
    base: np.ndarray
    nose: np.ndarray
    balls: dict
    ear_mode: str
    ear_rgba: np.ndarray


@dataclass(frozen=True, slots=True)
class Reward:
    """What one step of a task with a reward (a Gymnasium environment) earned, for judges and the page,
    never a DL input: the tick whose command was applied, the episode (from 0), the step within it (from
    1), the step's reward, the episode's return so far, and whether the episode ended with this step."""
    FIELDS = (("tick", INT), ("episode", INT), ("step", INT), ("reward", FLOAT), ("episode_return", FLOAT),
              ("done", BOOL))
    tick: int
    episode: int
    step: int
    reward: float
    episode_return: float
    done: bool

    def check(self, key: str) -> None:
        if self.episode < 0 or self.step < 1 or self.tick < 1:
            raise SchemaError(key, "step", f"episode {self.episode}, step {self.step}, tick {self.tick}: episodes "
                                           "count from 0, steps and ticks from 1")


@dataclass(frozen=True, slots=True)
class Episode:
    """An episode that ended: its number, steps, return, whether the task ended it (terminated) or a time
    limit did (truncated), and who drove it: steps per command mode (teacher, student, unsure)."""
    FIELDS = (("episode", INT), ("steps", INT), ("episode_return", FLOAT), ("terminated", BOOL),
              ("truncated", BOOL), ("modes", MAP), ("stamp", FLOAT))
    episode: int
    steps: int
    episode_return: float
    terminated: bool
    truncated: bool
    modes: dict
    stamp: float

    def check(self, key: str) -> None:
        if self.episode < 0 or self.steps < 1:
            raise SchemaError(key, "steps", f"episode {self.episode} of {self.steps} steps: episodes count from 0 "
                                            "and have a step at least")
        for mode, count in self.modes.items():
            if mode not in MODES or isinstance(count, bool) or not isinstance(count, int) or count < 0:
                raise SchemaError(key, f"modes.{mode}", f"expected a count of steps for one of "
                                                        f"{', '.join(MODES)}")
        if sum(self.modes.values()) > self.steps:
            raise SchemaError(key, "modes", f"{sum(self.modes.values())} steps counted by mode in an episode of "
                                            f"{self.steps}")
