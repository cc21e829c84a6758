"""Section V.B, ball seeking: inputs the colour blobs of the nose camera, outputs (forward, turn)
that the trot gait walks; the teacher seeks and approaches the pink ball.

DL runs at 5 Hz of simulated time here (mirroring: 30 Hz). The gait low-passes commands over
0.25 s, so faster decisions change little; every tick renders a camera frame (about 10 ms of
wall time, as much as the physics of a tenth of a second). Measured on seeds 0-1: the student
succeeds as often at 5 Hz as at 10 Hz, and a seed's protocol takes 0.18 instead of 0.28 wall
seconds per simulated second, which keeps the 10-seed benchmark well under 30 minutes.

A world is one AiboPlatform reset per episode from an arena seed (clutter from the seed), with
the balls placed by the experiment: a person putting the ball down, out of reach of the seed.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bus_schema.spaces import Spaces
from services.experiments.evaluate import figure5_error, half_range
from services.experiments.judges import REACH_RADIUS, nose_to_ball
from services.experiments.loop import Trace, tick
from services.perception.blobs import BlobDetector
from services.perception.slots import BlobSlots
from services.platforms.aibo.arena_layout import EYE_HEIGHT, arena_layout, in_sight, touches_clutter
from services.platforms.aibo.platform import AiboPlatform
from services.teachers.ballseek import ball_seek_teacher

BALLSEEK_RATE_HZ = 5.0
INPUT_LAYOUTS = ("colours", "slots")
BALLS = ("pink", "orange")  # the arena's balls; an experiment shows some and hides the others
NEAR, FAR = 0.5, 1.3  # ball distances (m) from the robot: beyond ~1.4 m a ball is under 6 pixels
MAX_DRAWS = 1000


def ball_spot(rng: np.random.Generator, near: float = NEAR, far: float = FAR, bearing=(-np.pi, np.pi),
              pose=((0.0, 0.0), 0.0), arena: int | None = None) -> tuple[float, float]:
    """A floor point `near`..`far` metres from the robot at `pose` ((x, y), yaw), bearing in the range
    given (radians, left positive), in the robot's frame. With `arena` (its seed), the point is drawn
    again until the robot can see it from where it stands and it touches no clutter: a person puts
    the ball down in view, not behind the clutter (where a robot that searches by turning on the spot
    never finds it) nor against it (where physics pushes it away, rolling)."""
    (x0, y0), yaw = pose
    layout = arena_layout(arena) if arena is not None else None
    for _ in range(MAX_DRAWS):
        distance, angle = rng.uniform(near, far), yaw + rng.uniform(*bearing)
        spot = float(x0 + distance * np.cos(angle)), float(y0 + distance * np.sin(angle))
        if layout is None or (not touches_clutter(layout, spot) and in_sight(layout, spot, eye=(x0, y0, EYE_HEIGHT))):
            return spot
    raise RuntimeError(f"no spot {near}-{far} m from {pose} in sight in arena {arena} after {MAX_DRAWS} draws")


@dataclass
class BallWorld:
    """The simulated Aibo in "move" mode, its camera and the blob detector, on a running clock."""

    seed: int
    platform: AiboPlatform = None
    detector: BlobDetector = field(default_factory=BlobDetector)
    clock: float = 0.0  # simulated seconds over all episodes, for one continuous trace
    rate_hz: float = BALLSEEK_RATE_HZ
    inputs: str = "slots"  # colour-blind slots (services/perception/slots.py), or "colours": the detector's layout

    def __post_init__(self):
        if self.inputs not in INPUT_LAYOUTS:
            raise ValueError(f"inputs must be one of {INPUT_LAYOUTS}, got {self.inputs!r}")
        self.platform = self.platform or AiboPlatform(seed=self.seed, command="move")
        self._slots = BlobSlots(self.detector) if self.inputs == "slots" else None
        box = self._slots.box() if self._slots else self.detector.box()
        self.spaces = Spaces(input=box, output=self.platform.spaces.output,
                             extra={"task": "ballseek", "rate_hz": self.rate_hz, "inputs": self.inputs})

    def make_teacher(self):
        """The pink-seeking teacher for this world's input layout."""
        return ball_seek_teacher(self.spaces)

    @property
    def sim(self):
        return self.platform.sim

    def start(self, arena_seed: int, balls: dict) -> None:
        """New episode: arena from `arena_seed`; `balls` maps colour to (x, y), absent colours hidden."""
        self.arena = arena_seed
        self.platform.reset(arena_seed)
        for name in BALLS:
            if name in balls:
                self.sim.place_ball(name, balls[name])
            else:
                self.sim.hide_ball(name)

    def pose(self) -> tuple[tuple[float, float], float]:
        position, _ = self.sim.base_pose()
        return (float(position[0]), float(position[1])), self.sim.base_yaw()

    def observe(self) -> np.ndarray:
        blobs = self.detector.detect(self.sim.render_camera())
        return self._slots.encode(blobs) if self._slots else blobs

    def run(self, seconds: float, learner, teacher=None, user=None, trace: Trace | None = None,
            target: str | None = None) -> float | None:
        """Algorithm 2 for `seconds`; the teacher is on while `user.teaching(t, unsure)` says so (always
        if user is None). Stops when the nose is within REACH_RADIUS of the `target` ball and returns
        the episode time then (None if never)."""
        dt = 1.0 / self.rate_hz
        unsure = False
        for _ in range(int(round(seconds * self.rate_hz))):
            t = self.sim.sim_time
            x = self.observe()
            on = teacher is not None and (user is None or user.teaching(self.clock + t, unsure))
            decision, y_hat, confidence = tick(x, [("teacher/ballseek", teacher)] if on else [], learner,
                                               output_space=self.spaces.output)
            unsure = decision.mode == "unsure"
            if trace is not None:
                trace.add(self.clock + t, x, decision, y_hat, confidence)
            self.platform.step(decision.y, dt)
            if target is not None and nose_to_ball(self.sim, target) < REACH_RADIUS:
                self.clock += self.sim.sim_time
                return t + dt
        self.clock += self.sim.sim_time
        return None

    def close(self) -> None:
        self.platform.close()


def ball_in_view(xs: np.ndarray, inputs: str, colour: str) -> np.ndarray:
    """Per row of inputs (n, dims), in either layout ("slots" or "colours"): is the `colour` ball in view."""
    detector = BlobDetector()
    column = 4 * list(detector.colours).index(colour)  # the colour's 'seen' in the detector's layout
    if inputs == "slots":
        slots = BlobSlots(detector)
        return np.array([slots.decode(x)[column] > 0.5 for x in xs], dtype=bool)
    return np.asarray(xs, dtype=np.float64)[:, column] > 0.5


def ballseek_error(trace: Trace, spaces: Spaces, teacher=None) -> np.ndarray:
    """Figure 5 for ball seeking: RMS over (forward, turn), each divided by its half-range so both count
    alike."""
    arrays = trace.arrays()
    return figure5_error(teacher or ball_seek_teacher(spaces), arrays["x"], arrays["student"],
                         scale=half_range(spaces.output))[1]
