"""Perception on the simulated nose camera: each ball is reported within a few pixels of where
the camera's view and projection matrices put the ball's centre (after JPEG, as on the bus)."""
from __future__ import annotations

import numpy as np
import pytest

from services.perception.blobs import BlobDetector
from services.perception.jpeg import decode_rgb, encode_rgb
from services.platforms.aibo.camera import HEIGHT, WIDTH, project
from services.platforms.aibo.sim import AiboSim

TOLERANCE_PX = 3.0
# ball spots in front of the robot, inside the clutter-free circle around its start
LAYOUTS = [((0.50, 0.10), (0.55, -0.12)), ((0.45, -0.05), (0.55, 0.15)), ((0.55, 0.0), (0.50, -0.10))]


@pytest.mark.parametrize(("pink", "orange"), LAYOUTS)
def test_each_ball_is_seen_where_the_camera_projects_it(pink, orange):
    detector = BlobDetector()
    with AiboSim(seed=5) as sim:
        sim.place_ball("pink", pink)
        sim.place_ball("orange", orange)
        sim.step(0.05)
        vector = detector.detect(decode_rgb(encode_rgb(sim.render_camera())))
        view, projection = sim.camera_matrices()
        for i, (name, centre) in enumerate(sim.ball_positions().items()):
            seen, x, y, area = vector[4 * i: 4 * i + 4]
            assert seen == 1, f"{name} not seen"
            expected = project(view, projection, centre)
            found = detector.to_pixels(x, y, WIDTH, HEIGHT)
            assert np.hypot(*(np.array(found) - expected)) < TOLERANCE_PX, \
                f"{name}: blob {found}, projection {expected}"
            assert 0 < area < 0.2


def test_hidden_ball_is_not_seen():
    with AiboSim(seed=5) as sim:
        sim.place_ball("pink", (0.4, 0.0))
        sim.hide_ball("orange")
        vector = BlobDetector().detect(sim.render_camera())
        assert vector[0] == 1 and np.array_equal(vector[4:], np.zeros(4))
