"""AiboSim: the simulated ERS-7 in its arena, one PyBullet client, stepped explicitly.

Nothing here runs on its own clock: `step(dt)` advances the physics by fixed substeps, so the
simulation runs as fast as the caller steps it (tests, benchmarks) or in real time when the
caller paces it. The same seed and the same calls give the same run, bit for bit.
"""
from __future__ import annotations

import contextlib
import os
import sys
import warnings

import numpy as np
import pybullet
from pybullet_utils.bullet_client import BulletClient

from services.platforms.aibo.arena import Arena
from services.platforms.aibo.camera import NoseCamera
from services.platforms.aibo.gait import MOVE_LIMITS, TrotGait, neutral_pose
from services.platforms.aibo.joints import JOINT_LIMITS, JOINT_NAMES, LEG_SLICE, LEGS
from services.platforms.aibo.model import URDF_PATH


@contextlib.contextmanager
def _stdout_to_stderr():
    sys.stdout.flush()
    saved = os.dup(1)
    os.dup2(2, 1)
    try:
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)

EAR_COLOURS = {"teacher": (1.0, 0.0, 0.0, 1.0), "student": (0.0, 0.0, 1.0, 1.0), "unsure": (0.0, 1.0, 0.0, 1.0)}
EAR_IDLE = (0.5, 0.5, 0.5, 1.0)  # before any mode is known
PHYSICS_HZ = 240
SETTLE_SECONDS = 0.5  # reset lets the robot land on its feet before the clock starts
# motor strength (N m) and position-loop gains; estimates that make a 1.65 kg robot walk firmly
LEG_FORCE, OTHER_FORCE = 2.5, 0.8
POSITION_GAIN, VELOCITY_GAIN = 0.35, 1.0
FOOT_FRICTION = 1.0
STOP_SMOOTHING = 0.08  # s: the watchdog brings a walking robot to a stand this fast (walking: 0.25)


class AiboSim:
    def __init__(self, seed: int = 0, gui: bool = False, physics_hz: int = PHYSICS_HZ, camera: NoseCamera | None = None,
                 gait: TrotGait | None = None):
        self.seed, self.physics_hz = seed, physics_hz
        self.camera = camera or NoseCamera()
        self.gait = gait or TrotGait()
        with _stdout_to_stderr():  # pybullet prints "argv[0]=" from C: stdout is never ours to fill
            self._client = BulletClient(connection_mode=self._connection_mode(gui))
        self._closed = False
        self.reset(seed)

    @staticmethod
    def _connection_mode(gui: bool) -> int:
        if gui and os.environ.get("DISPLAY"):
            return pybullet.GUI
        if gui:
            warnings.warn("AiboSim(gui=True) but DISPLAY is not set: running headless (DIRECT) instead", RuntimeWarning,
                          stacklevel=3)
        return pybullet.DIRECT

    # ---- episode -------------------------------------------------------------------------------

    def reset(self, seed: int | None = None) -> None:
        """Rebuild the world from scratch (a fresh solver state is what makes runs repeatable)."""
        self.seed = self.seed if seed is None else seed
        c = self._client
        c.resetSimulation()
        c.setGravity(0, 0, -9.81)
        c.setPhysicsEngineParameter(fixedTimeStep=1.0 / self.physics_hz, numSolverIterations=50,
                                    deterministicOverlappingPairs=1)
        self.arena = Arena(c, self.seed)
        self.gait.reset()
        self._load_robot()
        self._steps, self._clock = 0, 0.0
        self._mode, self._stopping = "joints", False
        self._movement = np.zeros(2)
        self._targets = neutral_pose(self.gait)
        self._ramp_from, self._ramp_steps, self._ramp_done = self._targets, 0, 0
        self._handled_mask = np.zeros(len(JOINT_NAMES), dtype=bool)
        self._handled_q = self._targets.copy()
        self.set_ear_mode(None)
        self._run(round(SETTLE_SECONDS * self.physics_hz))
        self._steps, self._clock = 0, 0.0

    def _load_robot(self) -> None:
        c = self._client
        pose = neutral_pose(self.gait)
        height = self.gait.height + 0.015  # feet start just above the floor and settle onto it
        self.robot = c.loadURDF(str(URDF_PATH), [0, 0, height], [0, 0, 0, 1], flags=c.URDF_USE_INERTIA_FROM_FILE)
        names = {c.getJointInfo(self.robot, j)[1].decode(): j for j in range(c.getNumJoints(self.robot))}
        links = {c.getJointInfo(self.robot, j)[12].decode(): j for j in range(c.getNumJoints(self.robot))}
        self._joints = [names[name] for name in JOINT_NAMES]
        self._nose, self._ears = links["nose"], (links["ear_left"], links["ear_right"])
        for j, q in zip(self._joints, pose):
            c.resetJointState(self.robot, j, float(q))
        self._paws = {leg: links[f"{leg}_shin"] for leg in LEGS}
        for paw in self._paws.values():
            # the anchor stops contact drift: without it a robot standing still slid 0.8 mm/s
            c.changeDynamics(self.robot, paw, lateralFriction=FOOT_FRICTION, frictionAnchor=1)
        self._forces = [LEG_FORCE if i < 12 else OTHER_FORCE for i in range(len(JOINT_NAMES))]

    # ---- commands -------------------------------------------------------------------------------

    def set_joint_targets(self, q, ramp_s: float = 0.0) -> np.ndarray:
        """Aim all 18 motors (radians, clipped to the limits); returns the targets applied,
        with handled joints showing the handler's value, since that is what they follow.
        ramp_s > 0: move the aim from where it is to q over ramp_s seconds (a first-order hold, as a
        servo controller does between the set points of a slower loop) instead of jumping to q."""
        self._ramp_from = self._aim()
        self._ramp_steps, self._ramp_done = max(0, round(ramp_s * self.physics_hz)), 0
        self._targets = np.clip(np.asarray(q, dtype=np.float64), JOINT_LIMITS[:, 0], JOINT_LIMITS[:, 1])
        self._mode = "joints"
        return np.where(self._handled_mask, self._handled_q, self._targets)

    def set_movement(self, forward: float, turn: float) -> np.ndarray:
        """Walk: (forward m/s, turn rad/s, left positive), clipped to MOVE_LIMITS; returns what is applied."""
        self._movement = np.clip([forward, turn], MOVE_LIMITS[:, 0], MOVE_LIMITS[:, 1]).astype(np.float64)
        self._mode, self._stopping = "move", False
        return self._movement.copy()

    def set_handled(self, mask, q=None) -> None:
        """Joints where `mask` is true follow `q` (a handler moving them by hand), whatever else commands them."""
        self._handled_mask = np.asarray(mask, dtype=bool).reshape(len(JOINT_NAMES)).copy()
        if q is not None:
            self._handled_q = np.clip(np.asarray(q, dtype=np.float64), JOINT_LIMITS[:, 0], JOINT_LIMITS[:, 1])

    def hold(self, stand: bool = False) -> None:
        """Watchdog: keep every motor where it is now; a walking robot first puts its feet down
        where they are (a trot frozen mid-stride stands on two diagonal paws, rocks and slides).
        stand=True: the legs go to the standing pose (a robot whose legs a learned gait moved)."""
        self._targets = self.joint_positions()
        self._ramp_steps = 0
        if stand:
            self._targets[LEG_SLICE] = self.gait.stand_pose()
        if self._mode == "move":
            self._movement = np.zeros(2)
            self._stopping = True

    # ---- time -----------------------------------------------------------------------------------

    def step(self, dt: float) -> None:
        """Advance by dt seconds of simulated time (whole physics substeps; remainders carry over)."""
        if dt < 0:
            raise ValueError(f"dt must be >= 0, got {dt}")
        self._clock += dt
        self._run(round(self._clock * self.physics_hz) - self._steps)

    def _run(self, substeps: int) -> None:
        c, h = self._client, 1.0 / self.physics_hz
        for _ in range(max(substeps, 0)):
            if self._ramp_done < self._ramp_steps:
                self._ramp_done += 1
            targets = self._aim()
            if self._mode == "move":
                targets[LEG_SLICE] = self.gait.targets(*self._movement, h, STOP_SMOOTHING if self._stopping else None)
            targets = np.where(self._handled_mask, self._handled_q, targets)
            c.setJointMotorControlArray(self.robot, self._joints, c.POSITION_CONTROL, targetPositions=targets.tolist(),
                                        forces=self._forces, positionGains=[POSITION_GAIN] * len(targets),
                                        velocityGains=[VELOCITY_GAIN] * len(targets))
            c.stepSimulation()
            self._steps += 1

    def _aim(self) -> np.ndarray:
        """The joint targets now: the last ones set, or the way there while a ramp runs."""
        if self._ramp_done >= self._ramp_steps:
            return self._targets.copy()
        return self._ramp_from + (self._targets - self._ramp_from) * (self._ramp_done / self._ramp_steps)

    @property
    def sim_time(self) -> float:
        """Simulated seconds since the last reset."""
        return self._steps / self.physics_hz

    # ---- sensing --------------------------------------------------------------------------------

    def joint_positions(self) -> np.ndarray:
        return np.array([s[0] for s in self._client.getJointStates(self.robot, self._joints)])

    def joint_velocities(self) -> np.ndarray:
        return np.array([s[1] for s in self._client.getJointStates(self.robot, self._joints)])

    def base_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Body position (m) and orientation quaternion (x, y, z, w) in the world."""
        position, orientation = self._client.getBasePositionAndOrientation(self.robot)
        return np.array(position), np.array(orientation)

    def base_yaw(self) -> float:
        return float(self._client.getEulerFromQuaternion(self.base_pose()[1])[2])

    def upright(self) -> float:
        """Cosine of the body's tilt: 1 level, 0 on its side, negative upside down."""
        rotation = np.array(self._client.getMatrixFromQuaternion(self.base_pose()[1])).reshape(3, 3)
        return float(rotation[2, 2])

    def paws_on_floor(self) -> tuple[str, ...]:
        """The legs ("fl", "fr", "rl", "rr") whose paw touches the floor now."""
        touching = {contact[3] for contact in self._client.getContactPoints(bodyA=self.robot, bodyB=self.arena.floor)}
        return tuple(leg for leg, paw in self._paws.items() if paw in touching)

    def nose_pose(self) -> tuple[np.ndarray, np.ndarray]:
        state = self._client.getLinkState(self.robot, self._nose, computeForwardKinematics=1)
        return np.array(state[4]), np.array(state[5])

    def camera_matrices(self) -> tuple[list[float], list[float]]:
        """(view, projection) of the nose camera now, column-major as pybullet gives them."""
        position, orientation = self.nose_pose()
        return self.camera.view_matrix(position, orientation), self.camera.projection_matrix()

    def render_camera(self) -> np.ndarray:
        """The nose camera's RGB frame, uint8, shape (160, 208, 3)."""
        position, orientation = self.nose_pose()
        return self.camera.render(self._client, position, orientation)

    # ---- arena and ears -------------------------------------------------------------------------

    def place_ball(self, name: str, xy) -> None:
        self.arena.place_ball(name, xy)

    def hide_ball(self, name: str) -> None:
        self.arena.hide_ball(name)

    def ball_positions(self) -> dict[str, np.ndarray]:
        return self.arena.ball_positions()

    def set_ear_mode(self, mode: str | None) -> None:
        """Light the ears for the arbitrator's mode: teacher red, student blue, unsure green (None: grey)."""
        if mode is not None and mode not in EAR_COLOURS:
            raise ValueError(f"unknown ear mode {mode!r}; expected one of {', '.join(EAR_COLOURS)}")
        rgba = EAR_IDLE if mode is None else EAR_COLOURS[mode]
        for ear in self._ears:
            self._client.changeVisualShape(self.robot, ear, rgbaColor=list(rgba))
        self._ear_mode = mode

    @property
    def ear_mode(self) -> str | None:
        return self._ear_mode

    def ear_colours(self) -> list[tuple[float, ...]]:
        """The ears' colours as the renderer holds them (read back from pybullet, not from memory)."""
        shapes = self._client.getVisualShapeData(self.robot)
        return [tuple(s[7]) for s in shapes if s[1] in self._ears]

    # ---- lifetime -------------------------------------------------------------------------------

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._client.disconnect()

    def __enter__(self) -> AiboSim:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
