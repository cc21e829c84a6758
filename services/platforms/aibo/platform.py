"""AiboPlatform: the simulated ERS-7 behind the Platform contract (services/platforms/base.py).

Three command modes, the paper's two experiments and a learned gait:
- "joints" (mirroring): input the 18 joint positions, output 18 joint targets (rad);
- "move" (ball seeking): input still the 18 joint positions (the ball-seeking input comes from
  the perception process instead), output (forward m/s, turn rad/s) walked by the trot gait;
- "legs" (the walk level of a hierarchy): output the 12 leg joint targets, head and tail at
  rest; with inputs="phase" the input is the gait clock's phase as (sine, cosine), the one
  thing a gait needs to know of itself that a movement command does not say.
`sim` is public: the platform service takes camera frames, ears, handler, arena and clock from it.
"""
from __future__ import annotations

import numpy as np

from bus_schema.spaces import Box, Spaces
from services.platforms.aibo.camera import HEIGHT, VERTICAL_FOV_DEG, WIDTH
from services.platforms.aibo.gait import MOVE_LIMITS, MOVE_NAMES, MOVE_UNITS, neutral_pose
from services.platforms.aibo.joints import JOINT_LIMITS, JOINT_NAMES, LEG_SLICE
from services.platforms.aibo.sim import PHYSICS_HZ, AiboSim

COMMAND_MODES = ("joints", "move", "legs")
INPUT_MODES = ("joints", "phase")
# plain floats, not numpy scalars: spaces travel as data (msgpack, JSON)
JOINTS_BOX = Box(tuple(map(float, JOINT_LIMITS[:, 0])), tuple(map(float, JOINT_LIMITS[:, 1])), JOINT_NAMES,
                 ("rad",) * len(JOINT_NAMES))
MOVE_BOX = Box(tuple(map(float, MOVE_LIMITS[:, 0])), tuple(map(float, MOVE_LIMITS[:, 1])), MOVE_NAMES, MOVE_UNITS)
LEGS_BOX = Box(JOINTS_BOX.low[LEG_SLICE], JOINTS_BOX.high[LEG_SLICE], JOINTS_BOX.names[LEG_SLICE],
               JOINTS_BOX.units[LEG_SLICE])
PHASE_BOX = Box((-1.0, -1.0), (1.0, 1.0), ("phase_sin", "phase_cos"), ("", ""))
OUTPUT_BOXES = {"joints": JOINTS_BOX, "move": MOVE_BOX, "legs": LEGS_BOX}


class AiboPlatform:
    def __init__(self, seed: int = 0, command: str = "joints", camera: bool = True, gui: bool = False,
                 physics_hz: int = PHYSICS_HZ, inputs: str = "joints"):
        if command not in COMMAND_MODES:
            raise ValueError(f"command must be one of {COMMAND_MODES}, got {command!r}")
        if inputs not in INPUT_MODES:
            raise ValueError(f"inputs must be one of {INPUT_MODES}, got {inputs!r}")
        self.seed, self.command, self.camera, self.gui, self.physics_hz = seed, command, camera, gui, physics_hz
        self.inputs = inputs
        extra = {"platform": "aibo", "command": command, "physics_hz": physics_hz}
        if command != "joints":  # what an upper level (ball seeking) asks of a walking robot
            extra["movement"] = MOVE_BOX.to_dict()
        if camera:
            extra["camera"] = {"width": WIDTH, "height": HEIGHT, "vertical_fov_deg": VERTICAL_FOV_DEG,
                               "encoding": "jpeg"}
        self.sim = AiboSim(seed=seed, gui=gui, physics_hz=physics_hz)
        if inputs == "phase":
            extra["gait_period_s"] = self.sim.gait.period
        self.spaces = Spaces(input=JOINTS_BOX if inputs == "joints" else PHASE_BOX, output=OUTPUT_BOXES[command],
                             extra=extra)
        self._rest = neutral_pose(self.sim.gait)  # "legs": the head and tail stay here
        self._holding = False
        # a walking robot's watchdog puts its feet down (on four paws after 0.22-0.30 s, docs/aibo.md)
        self.hold_settle_seconds = 0.0 if command == "joints" else 0.5

    def reset(self, seed: int | None = None) -> np.ndarray:
        self.sim.reset(self.seed if seed is None else seed)
        self._holding = False
        return self.observe()

    def observe(self) -> np.ndarray:
        """The 18 joint positions, or the gait clock's phase (inputs="phase"). Joints are clipped to
        the declared limits: the physics solver lets a joint pressed against its stop overshoot by a
        few milliradians, which the contract must not show."""
        if self.inputs == "phase":
            angle = 2 * np.pi * self.sim.sim_time / self.sim.gait.period
            return np.array([np.sin(angle), np.cos(angle)])
        return np.clip(self.sim.joint_positions(), JOINT_LIMITS[:, 0], JOINT_LIMITS[:, 1])

    def step(self, command: np.ndarray, dt: float) -> np.ndarray:
        command = np.asarray(command, dtype=np.float64)
        if command.shape != (self.spaces.output.dims,):
            raise ValueError(f"expected {self.spaces.output.dims} command values for the aibo in {self.command!r} "
                             f"mode, got shape {command.shape}; see platform.spaces.output.names")
        command = self.spaces.output.clip(command)
        if self.command == "joints":
            applied = self.sim.set_joint_targets(command)
        elif self.command == "legs":
            pose = self._rest.copy()
            pose[LEG_SLICE] = command
            # ramped over the tick: a learned gait's targets held for a 60 Hz tick walk worse than the
            # same targets moved smoothly (docs/aibo.md, "Walking")
            applied = self.sim.set_joint_targets(pose, ramp_s=dt)[LEG_SLICE]
        else:
            applied = self.sim.set_movement(*command)
        self._holding = False
        self.sim.step(dt)
        return applied

    def hold(self, dt: float) -> None:
        """Watchdog: stop walking, feet down, and keep the other joints where they were when
        commands stopped (captured once, so that a long hold does not creep under gravity)."""
        if not self._holding:
            self.sim.hold(stand=self.command == "legs")
            self._holding = True
        self.sim.step(dt)

    def close(self) -> None:
        self.sim.close()

    def __enter__(self) -> AiboPlatform:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
