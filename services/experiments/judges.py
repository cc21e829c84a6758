"""Episode outcomes for ball seeking. Distances are from the nose (the camera) to the ball's
centre in 3-D, the literal reading of "brings the nose within 0.2 m of the ball": with the nose
18.6 cm up and the ball's centre 4 cm up, that means within about 14 cm on the floor.
"""
from __future__ import annotations

import numpy as np

REACH_RADIUS = 0.2  # metres, the success criterion


def nose_distance(nose_xyz, ball_xyz) -> float:
    return float(np.linalg.norm(np.asarray(nose_xyz, dtype=np.float64) - np.asarray(ball_xyz, dtype=np.float64)))


def nose_to_ball(sim, ball: str) -> float:
    """Distance now from the simulated Aibo's nose to the named ball ("pink" or "orange")."""
    return nose_distance(sim.nose_pose()[0], sim.ball_positions()[ball])


def reached(nose_track: np.ndarray, ball_track: np.ndarray, radius: float = REACH_RADIUS) -> bool:
    """From recorded (n, 3) positions: did the nose ever come within `radius` of the ball?
    Both "success" (pink) and "approaches orange" are this judge on their ball."""
    nose_track, ball_track = np.atleast_2d(nose_track), np.atleast_2d(ball_track)
    return bool(np.any(np.linalg.norm(nose_track - ball_track, axis=1) < radius))


def first_reach_time(t: np.ndarray, nose_track: np.ndarray, ball_track: np.ndarray,
                     radius: float = REACH_RADIUS) -> float | None:
    """Time of the first tick within `radius`, or None if never."""
    close = np.linalg.norm(np.atleast_2d(nose_track) - np.atleast_2d(ball_track), axis=1) < radius
    hits = np.flatnonzero(close)
    return float(np.asarray(t)[hits[0]]) if len(hits) else None
