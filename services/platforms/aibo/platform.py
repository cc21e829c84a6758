"""AiboPlatform: the simulated ERS-7 behind the Platform contract (services/platforms/base.py).

Two command modes, the paper's two experiments:
- "joints" (mirroring): input the 18 joint positions, output 18 joint targets (rad);
- "move" (ball seeking): input still the 18 joint positions (the ball-seeking input comes from
  the perception process instead), output (forward m/s, turn rad/s) walked by the trot gait.
`sim` is public: the platform service takes camera frames, ears, handler, arena and clock from it.
"""
from __future__ import annotations

import numpy as np

from bus_schema.spaces import Box, Spaces
from services.platforms.aibo.camera import HEIGHT, VERTICAL_FOV_DEG, WIDTH
from services.platforms.aibo.gait import MOVE_LIMITS, MOVE_NAMES, MOVE_UNITS
from services.platforms.aibo.joints import JOINT_LIMITS, JOINT_NAMES
from services.platforms.aibo.sim import PHYSICS_HZ, AiboSim

COMMAND_MODES = ("joints", "move")
# plain floats, not numpy scalars: spaces travel as data (msgpack, JSON)
JOINTS_BOX = Box(tuple(map(float, JOINT_LIMITS[:, 0])), tuple(map(float, JOINT_LIMITS[:, 1])), JOINT_NAMES,
                 ("rad",) * len(JOINT_NAMES))
MOVE_BOX = Box(tuple(map(float, MOVE_LIMITS[:, 0])), tuple(map(float, MOVE_LIMITS[:, 1])), MOVE_NAMES, MOVE_UNITS)


class AiboPlatform:
    def __init__(self, seed: int = 0, command: str = "joints", camera: bool = True, gui: bool = False,
                 physics_hz: int = PHYSICS_HZ):
        if command not in COMMAND_MODES:
            raise ValueError(f"command must be one of {COMMAND_MODES}, got {command!r}")
        self.seed, self.command, self.camera, self.gui, self.physics_hz = seed, command, camera, gui, physics_hz
        extra = {"platform": "aibo", "command": command, "physics_hz": physics_hz}
        if camera:
            extra["camera"] = {"width": WIDTH, "height": HEIGHT, "vertical_fov_deg": VERTICAL_FOV_DEG,
                               "encoding": "jpeg"}
        self.spaces = Spaces(input=JOINTS_BOX, output=JOINTS_BOX if command == "joints" else MOVE_BOX, extra=extra)
        self.sim = AiboSim(seed=seed, gui=gui, physics_hz=physics_hz)
        self._holding = False
        # a walking robot's watchdog puts its feet down (on four paws after 0.22-0.30 s, docs/aibo.md)
        self.hold_settle_seconds = 0.5 if command == "move" else 0.0

    def reset(self, seed: int | None = None) -> np.ndarray:
        self.sim.reset(self.seed if seed is None else seed)
        self._holding = False
        return self.observe()

    def observe(self) -> np.ndarray:
        """The 18 joint positions. Clipped to the declared limits: the physics solver lets a joint
        pressed against its stop overshoot by a few milliradians, which the contract must not show."""
        return np.clip(self.sim.joint_positions(), JOINT_LIMITS[:, 0], JOINT_LIMITS[:, 1])

    def step(self, command: np.ndarray, dt: float) -> np.ndarray:
        command = np.asarray(command, dtype=np.float64)
        if command.shape != (self.spaces.output.dims,):
            raise ValueError(f"expected {self.spaces.output.dims} command values for the aibo in {self.command!r} "
                             f"mode, got shape {command.shape}; see platform.spaces.output.names")
        command = self.spaces.output.clip(command)
        if self.command == "joints":
            applied = self.sim.set_joint_targets(command)
        else:
            applied = self.sim.set_movement(*command)
        self._holding = False
        self.sim.step(dt)
        return applied

    def hold(self, dt: float) -> None:
        """Watchdog: stop walking, feet down, and keep the other joints where they were when
        commands stopped (captured once, so that a long hold does not creep under gravity)."""
        if not self._holding:
            self.sim.hold()
            self._holding = True
        self.sim.step(dt)

    def close(self) -> None:
        self.sim.close()

    def __enter__(self) -> AiboPlatform:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
