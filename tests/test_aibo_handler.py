"""The handler: tail along a smooth seeded path over its range, distractors random; handled joints
follow the handler, not the arbitrator."""
from __future__ import annotations

import numpy as np

from services.platforms.aibo.handler import MIRRORING_DISTRACTORS, OTHER_16, Handler, tail_trajectory
from services.platforms.aibo.joints import JOINT_INDEX, JOINT_LIMITS, TAIL_PAN, TAIL_TILT
from services.platforms.aibo.sim import AiboSim


def test_tail_path_is_smooth_seeded_and_covers_the_range():
    times = np.arange(0.0, 120.0, 0.05)
    path = np.array([tail_trajectory(t, seed=1) for t in times])
    limits = JOINT_LIMITS[[TAIL_TILT, TAIL_PAN]]
    span = limits[:, 1] - limits[:, 0]
    assert np.all(path >= limits[:, 0]) and np.all(path <= limits[:, 1])
    assert np.all(path.max(0) - path.min(0) > 0.8 * span)  # sweeps most of each joint's range
    assert np.abs(np.diff(path, axis=0)).max() < 0.05 * span.max()  # no jumps between 50 ms samples
    assert not np.allclose(path, [tail_trajectory(t, seed=2) for t in times])
    assert np.array_equal(path[7], tail_trajectory(times[7], seed=1))


def test_handler_masks_tail_and_sixteen_distractors_within_limits():
    handler = Handler(seed=0)
    assert len(OTHER_16) == 16
    for t in (0.0, 0.7, 13.2):
        mask, q = handler.at(t)
        assert mask.all() and np.all((q >= JOINT_LIMITS[:, 0]) & (q <= JOINT_LIMITS[:, 1]))
    assert not np.allclose(handler.at(1.0)[1], handler.at(5.0)[1])
    mask, _ = Handler(distractors=MIRRORING_DISTRACTORS).at(0.0)
    assert not mask[JOINT_INDEX["head_pan"]] and mask[TAIL_PAN]


def test_handled_joints_follow_the_handler_not_the_arbitrator():
    handler = Handler(seed=0, distractors=())
    with AiboSim(seed=0) as sim:
        arbitrator = sim.joint_positions()
        arbitrator[[TAIL_TILT, TAIL_PAN]] = JOINT_LIMITS[[TAIL_TILT, TAIL_PAN], 0]  # asks for the opposite corner
        for k in range(40):
            mask, q = handler.at(k * 0.05)
            sim.set_handled(mask, q)
            applied = sim.set_joint_targets(arbitrator)
            sim.step(0.05)
        assert np.allclose(applied[[TAIL_TILT, TAIL_PAN]], q[[TAIL_TILT, TAIL_PAN]])
        assert np.allclose(sim.joint_positions()[[TAIL_TILT, TAIL_PAN]], q[[TAIL_TILT, TAIL_PAN]], atol=0.1)
        sim.set_handled(np.zeros(18, dtype=bool))
        sim.step(1.0)  # let go: the tail returns to the arbitrator's command
        assert np.allclose(sim.joint_positions()[[TAIL_TILT, TAIL_PAN]], arbitrator[[TAIL_TILT, TAIL_PAN]], atol=0.05)
