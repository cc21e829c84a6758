"""AiboSim: seeded arena and runs, clock, camera frames, ears, balls, lifetime."""
from __future__ import annotations

import numpy as np
import pytest

from services.platforms.aibo.sim import EAR_COLOURS, AiboSim


def walk_trace(seed: int) -> np.ndarray:
    with AiboSim(seed=seed) as sim:
        sim.set_movement(0.1, 0.3)
        sim.step(1.5)
        position, orientation = sim.base_pose()
        return np.concatenate([sim.joint_positions(), position, orientation, *sim.ball_positions().values()])


def test_same_seed_same_run_and_other_seed_other_arena():
    assert np.array_equal(walk_trace(3), walk_trace(3))
    with AiboSim(seed=3) as a, AiboSim(seed=4) as b:
        assert not np.allclose(a.ball_positions()["pink"], b.ball_positions()["pink"])


def test_clock_counts_whole_substeps_and_carries_remainders():
    with AiboSim(seed=0, physics_hz=240) as sim:
        assert sim.sim_time == 0.0
        for _ in range(100):
            sim.step(0.01)  # 2.4 substeps each: the remainders must add up, not be lost
        assert sim.sim_time == pytest.approx(1.0, abs=1 / 240)


@pytest.mark.parametrize("mode", list(EAR_COLOURS))
def test_ear_colour_follows_mode(mode):
    with AiboSim(seed=0) as sim:
        sim.set_ear_mode(mode)
        assert sim.ear_mode == mode
        colours = sim.ear_colours()
        assert len(colours) == 2 and all(c == pytest.approx(EAR_COLOURS[mode]) for c in colours)


def test_ear_modes_are_red_blue_green_and_unknown_mode_is_refused():
    assert EAR_COLOURS["teacher"][:3] == (1.0, 0.0, 0.0)
    assert EAR_COLOURS["student"][:3] == (0.0, 0.0, 1.0)
    assert EAR_COLOURS["unsure"][:3] == (0.0, 1.0, 0.0)
    with AiboSim(seed=0) as sim, pytest.raises(ValueError, match="unknown ear mode 'sleepy'"):
        sim.set_ear_mode("sleepy")


def test_camera_frame_is_ers7_sized_rgb():
    with AiboSim(seed=0) as sim:
        frame = sim.render_camera()
        assert frame.shape == (160, 208, 3) and frame.dtype == np.uint8 and frame.std() > 5


def test_balls_can_be_placed_and_hidden():
    with AiboSim(seed=0) as sim:
        sim.place_ball("pink", (0.4, 0.1))
        sim.hide_ball("orange")
        sim.step(0.5)
        balls = sim.ball_positions()
        assert balls["pink"][:2] == pytest.approx([0.4, 0.1], abs=0.01)
        assert np.hypot(*balls["orange"][:2]) > 10
        with pytest.raises(KeyError, match="no ball named 'green'"):
            sim.place_ball("green", (0, 0))


def test_gui_without_display_warns_and_runs_headless(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    with pytest.warns(RuntimeWarning, match="DISPLAY is not set"):
        sim = AiboSim(seed=0, gui=True)
    sim.close()
    sim.close()  # idempotent
