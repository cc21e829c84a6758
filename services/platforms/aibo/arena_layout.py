"""Where the arena's things stand, as a pure function of its seed (no PyBullet), and whether the
robot can see a spot from where it starts. `arena.Arena` builds the scene from this layout;
experiments and the live demo ask `in_sight` before a person puts a ball down.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

HALF_SIZE = 1.5  # metres from the centre to each wall
BALL_RADIUS = 0.04
BALL_NAMES = ("pink", "orange")
CLUTTER_COLOURS = ((0.2, 0.3, 0.75, 1), (0.2, 0.55, 0.3, 1), (0.35, 0.35, 0.38, 1), (0.1, 0.45, 0.5, 1), (0.9, 0.9, 0.9,
                                                                                                          1))
CLUTTER_COUNT = 7
KEEP_CLEAR = 0.5  # no clutter or ball this close to where the robot starts (the origin)
EYE_HEIGHT = 0.176  # the standing robot's nose camera above the floor (m)


@dataclass(frozen=True)
class Clutter:
    """A static box: centre (x, y, z), half extents (x, y, z), yaw about z, colour."""

    centre: tuple[float, float, float]
    half: tuple[float, float, float]
    yaw: float
    rgba: tuple[float, float, float, float]


@dataclass(frozen=True)
class Layout:
    clutter: tuple[Clutter, ...]
    balls: dict  # name -> (x, y) where the seed puts it


def _free_spot(rng: np.random.Generator, occupied: list, margin: float) -> tuple[float, float]:
    """A random floor point away from the robot's start, the walls and what already stands."""
    for _ in range(1000):
        xy = rng.uniform(-HALF_SIZE + 0.2, HALF_SIZE - 0.2, size=2)
        if np.hypot(*xy) < KEEP_CLEAR + margin:
            continue
        if all(np.hypot(*(xy - spot)) > size + margin for spot, size in occupied):
            return float(xy[0]), float(xy[1])
    raise RuntimeError("arena too crowded to place another object; lower CLUTTER_COUNT")


def arena_layout(seed: int) -> Layout:
    """The clutter and the balls' seeded spots; the same seed gives the same layout."""
    rng, occupied, clutter = np.random.default_rng(seed), [], []
    for _ in range(CLUTTER_COUNT):
        half = rng.uniform([0.04, 0.04, 0.03], [0.12, 0.12, 0.12])
        footprint = float(np.hypot(half[0], half[1]))
        x, y = _free_spot(rng, occupied, margin=footprint)
        occupied.append((np.array([x, y]), footprint))
        rgba = CLUTTER_COLOURS[int(rng.integers(len(CLUTTER_COLOURS)))]
        clutter.append(Clutter((x, y, float(half[2])), tuple(float(h) for h in half), float(rng.uniform(0, np.pi)),
                               rgba))
    balls = {}
    for name in BALL_NAMES:
        balls[name] = _free_spot(rng, occupied, margin=0.1)
        occupied.append((np.array(balls[name]), BALL_RADIUS))
    return Layout(tuple(clutter), balls)


def _segment_hits_box(start: np.ndarray, end: np.ndarray, box: Clutter) -> bool:
    """Slab test of the segment start-end against the box, in the box's own frame."""
    c, s = np.cos(-box.yaw), np.sin(-box.yaw)
    rotate = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    a, b = rotate @ (start - box.centre), rotate @ (end - box.centre)
    direction, half = b - a, np.asarray(box.half)
    low, high = 0.0, 1.0
    for axis in range(3):
        if abs(direction[axis]) < 1e-12:
            if abs(a[axis]) > half[axis]:
                return False
            continue
        t1, t2 = sorted(((-half[axis] - a[axis]) / direction[axis], (half[axis] - a[axis]) / direction[axis]))
        low, high = max(low, t1), min(high, t2)
        if low > high:
            return False
    return True


def touches_clutter(layout: Layout, xy, radius: float = BALL_RADIUS) -> bool:
    """Would a ball of `radius` at `xy` touch a clutter box? (Physics would push it out, rolling.)"""
    for box in layout.clutter:
        c, s = np.cos(-box.yaw), np.sin(-box.yaw)
        dx, dy = float(xy[0]) - box.centre[0], float(xy[1]) - box.centre[1]
        if abs(c * dx - s * dy) <= box.half[0] + radius and abs(s * dx + c * dy) <= box.half[1] + radius:
            return True
    return False


def in_sight(layout: Layout, xy, eye=(0.0, 0.0, EYE_HEIGHT)) -> bool:
    """Can a robot whose camera is at `eye` see a ball at `xy` past the clutter? True when the line
    to the ball's centre or to its top is clear (turning on the spot, it will face it)."""
    eye = np.asarray(eye, dtype=np.float64)
    for z in (BALL_RADIUS, 2 * BALL_RADIUS):
        target = np.array([float(xy[0]), float(xy[1]), z])
        if not any(_segment_hits_box(eye, target, box) for box in layout.clutter):
            return True
    return False
