"""A trot: a movement command (forward m/s, turn rad/s) becomes 12 leg joint targets.

Diagonal legs (front-left with rear-right, front-right with rear-left) swing together, half a
period apart. During stance a foot slides backwards under its shoulder at the velocity the
commanded body motion has at that foot, so the body is pushed by friction with the floor (the
base is never moved by hand); during swing the foot lifts and returns forward. Joint targets
come from closed-form inverse kinematics of the ERS-7 leg (pitch, roll, knee).
"""
from __future__ import annotations

import numpy as np

from services.platforms.aibo import dimensions as dims
from services.platforms.aibo.joints import HEAD_TILT, JOINT_LIMITS, JOINT_NAMES, LEG_SLICE, LEGS, MOUTH, TAIL_TILT

PHASE_OFFSET = {"fl": 0.0, "rr": 0.0, "fr": 0.5, "rl": 0.5}
# the movement command's range: (forward m/s, turn rad/s), backwards walking included
MOVE_NAMES = ("forward", "turn")
MOVE_UNITS = ("m/s", "rad/s")
MOVE_LIMITS = np.array([[-0.15, 0.15], [-0.8, 0.8]])
LIFT_RAMP = 0.25  # pose_at: full lift from a quarter of the command range


def leg_fk(leg: str, angles) -> np.ndarray:
    """Foot centre relative to the shoulder, body axes, for (pitch, roll, knee) in radians."""
    front, left = dims.leg_side(leg)
    pitch, roll, knee = angles
    shin = dims.SHIN["front" if front > 0 else "rear"]
    x1, below = front * shin * np.sin(knee), dims.THIGH + shin * np.cos(knee)
    phi = left * roll
    y, z1 = below * np.sin(phi), -below * np.cos(phi)
    theta = -front * pitch
    return np.array([x1 * np.cos(theta) + z1 * np.sin(theta), y, -x1 * np.sin(theta) + z1 * np.cos(theta)])


def leg_ik(leg: str, foot) -> np.ndarray:
    """(pitch, roll, knee) putting the foot centre at `foot` (relative to the shoulder, body axes).
    The knee always bends positively; out-of-reach targets are pulled back within reach."""
    front, left = dims.leg_side(leg)
    shin = dims.SHIN["front" if front > 0 else "rear"]
    x, y, z = foot
    reach = np.sqrt(x * x + y * y + z * z)
    reach = np.clip(reach, abs(dims.THIGH - shin) + 1e-3, dims.THIGH + shin - 1e-3)
    knee = np.arccos(np.clip((reach ** 2 - dims.THIGH ** 2 - shin ** 2) / (2 * dims.THIGH * shin), -1.0, 1.0))
    below = dims.THIGH + shin * np.cos(knee)
    phi = np.arcsin(np.clip(y / below, -1.0, 1.0))
    x1, z1 = front * shin * np.sin(knee), -below * np.cos(phi)
    theta = np.arctan2(x, z) - np.arctan2(x1, z1)
    theta = (theta + np.pi) % (2 * np.pi) - np.pi
    return np.array([-front * theta, left * phi, knee])


class TrotGait:
    """Stateful trot generator: call `targets(forward, turn, dt)` once per physics substep."""

    def __init__(self, period: float = 0.36, duty: float = 0.5, lift: float = 0.022, height: float = 0.112,
                 splay: float = 0.012, max_stride: float = 0.045, smoothing: float = 0.25, still_below: float = 1e-3):
        self.period, self.duty, self.lift, self.height = period, duty, lift, height
        self.splay, self.max_stride, self.smoothing, self.still_below = splay, max_stride, smoothing, still_below
        self.reset()

    def reset(self) -> None:
        self._phase = 0.0
        self._command = np.zeros(2)  # low-passed (forward, turn): no step changes reach the feet
        self._activity = 0.0  # 0 standing, 1 stepping; ramps so feet settle rather than drop

    def _foot_home(self, leg: str) -> np.ndarray:
        _, left = dims.leg_side(leg)
        return np.array([0.0, left * self.splay, -self.height])

    def stand_pose(self) -> np.ndarray:
        return np.concatenate([leg_ik(leg, self._foot_home(leg)) for leg in LEGS])

    def _stride(self, leg: str, command: np.ndarray) -> np.ndarray:
        """Foot travel over one stance: the commanded body velocity at this foot times stance time."""
        front, left = dims.leg_side(leg)
        at_x, at_y = front * dims.SHOULDER_X, left * (dims.SHOULDER_Y + self.splay)
        forward, turn = command
        velocity = np.array([forward - turn * at_y, turn * at_x])
        stride = velocity * self.duty * self.period
        length = float(np.linalg.norm(stride))
        return stride if length <= self.max_stride else stride * (self.max_stride / length)

    def _foot(self, leg: str, phase: float, command: np.ndarray, activity: float) -> np.ndarray:
        phase = (phase + PHASE_OFFSET[leg]) % 1.0
        stride = self._stride(leg, command)
        foot = self._foot_home(leg)
        if phase < self.duty:  # stance: slide from front to back
            foot[:2] += stride * (0.5 - phase / self.duty)
        else:  # swing: lift and return with a smooth start and end
            s = (phase - self.duty) / (1.0 - self.duty)
            foot[:2] += stride * ((1.0 - np.cos(np.pi * s)) / 2.0 - 0.5)
            foot[2] += self.lift * activity * np.sin(np.pi * s)
        return foot

    def _legs(self, phase: float, command: np.ndarray, activity: float) -> np.ndarray:
        return np.concatenate([leg_ik(leg, self._foot(leg, phase, command, activity)) for leg in LEGS])

    def pose_at(self, forward: float, turn: float, phase: float) -> np.ndarray:
        """The 12 leg joint targets at gait phase `phase` (0..1) under a steady command, without
        state: the trot as a function a learner can be taught (the walk level's demonstrator).
        The feet lift in proportion to the command up to a quarter of its range, so a robot asked
        to stand stands (trotting in place, this robot drifts ~7 cm/s)."""
        command = np.array([forward, turn], dtype=np.float64)
        share = np.max(np.abs(command) / MOVE_LIMITS[:, 1])
        return self._legs(phase, command, float(min(1.0, share / LIFT_RAMP)))

    def targets(self, forward: float, turn: float, dt: float, smoothing: float | None = None) -> np.ndarray:
        """Advance the gait by dt seconds under the command, low-passed over `smoothing` seconds
        (default: the gait's own); returns 12 leg joint targets (rad)."""
        blend = 1.0 - np.exp(-dt / (smoothing or self.smoothing))
        self._command += blend * (np.array([forward, turn], dtype=np.float64) - self._command)
        moving = abs(forward) > self.still_below or abs(turn) > self.still_below
        self._activity += blend * (float(moving) - self._activity)
        if self._activity > 1e-3:
            self._phase = (self._phase + dt / self.period) % 1.0
        return self._legs(self._phase, self._command, self._activity)


# The camera sees 45 degrees top to bottom. Tilted 0.35 rad down, a ball at the forepaws stays in view
# until 0.17 m from the nose (at 0.25 rad it was lost at 0.195 m, the very edge of ball seeking's
# "within 0.2 m"), and a ball 1.37 m away is still seen (that far, its blob is a few pixels). 0.4 rad
# sees closer still (0.15 m); it made the robot creep more when the watchdog held it mid-stride (the
# watchdog now stands it on four paws; 0.4 was not tried again).
REST_HEAD_TILT = -0.35


def neutral_pose(gait: TrotGait | None = None) -> np.ndarray:
    """All 18 motors at rest: standing, looking down at the floor ahead, mouth closed, tail up."""
    q = np.zeros(len(JOINT_NAMES))
    q[LEG_SLICE] = (gait or TrotGait()).stand_pose()
    q[HEAD_TILT], q[MOUTH], q[TAIL_TILT] = REST_HEAD_TILT, -0.06, 0.35
    return np.clip(q, JOINT_LIMITS[:, 0], JOINT_LIMITS[:, 1])
