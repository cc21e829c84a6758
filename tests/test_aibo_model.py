"""The Aibo model: 18 named motors in the agreed order, within their ERS-7 limits."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pybullet
import pytest

from services.platforms.aibo import JOINT_LIMITS, JOINT_NAMES
from services.platforms.aibo.dimensions import total_mass
from services.platforms.aibo.gait import leg_fk, leg_ik
from services.platforms.aibo.model import URDF_PATH, build_urdf
from services.platforms.aibo.sim import AiboSim

EXPECTED_ORDER = tuple(f"{leg}_{j}" for leg in ("fl", "fr", "rl", "rr") for j in ("shoulder_pitch", "shoulder_roll",
                                                                                  "knee")) + (
    "head_tilt", "head_pan", "head_nod", "mouth", "tail_tilt", "tail_pan")


def test_joint_names_in_agreed_order():
    assert JOINT_NAMES == EXPECTED_ORDER
    assert JOINT_LIMITS.shape == (18, 2) and np.all(JOINT_LIMITS[:, 0] < JOINT_LIMITS[:, 1])


@pytest.mark.live
def test_names_import_without_pybullet():
    code = "import sys, services.platforms.aibo as a; assert len(a.JOINT_NAMES) == 18; print('pybullet' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_urdf_is_what_the_generator_writes():
    assert URDF_PATH.read_text() == build_urdf.urdf(), "run python -m services.platforms.aibo.model.build_urdf"


def test_urdf_has_the_18_revolute_joints_with_their_limits():
    client = pybullet.connect(pybullet.DIRECT)
    try:
        robot = pybullet.loadURDF(str(URDF_PATH), physicsClientId=client)
        info = [pybullet.getJointInfo(robot, j, physicsClientId=client) for j in range(pybullet.getNumJoints(robot,
                                                                                                             physicsClientId=client))]
        revolute = {i[1].decode(): (i[8], i[9]) for i in info if i[2] == pybullet.JOINT_REVOLUTE}
        assert set(revolute) == set(JOINT_NAMES)
        for name, (low, high) in zip(JOINT_NAMES, JOINT_LIMITS):
            assert revolute[name] == pytest.approx((low, high), abs=1e-5), name
        mass = sum(pybullet.getDynamicsInfo(robot, link, physicsClientId=client)[0] for link in range(-1, len(info)))
        assert mass == pytest.approx(total_mass()) and 1.5 < mass < 1.8  # the ERS-7 weighs ~1.65 kg
    finally:
        pybullet.disconnect(client)


@pytest.mark.parametrize("leg", ["fl", "fr", "rl", "rr"])
def test_leg_inverse_kinematics_inverts_forward(leg):
    rng = np.random.default_rng(0)
    for angles in rng.uniform([-1.0, -0.1, 0.4], [1.0, 0.6, 1.8], size=(50, 3)):
        assert leg_fk(leg, leg_ik(leg, leg_fk(leg, angles))) == pytest.approx(leg_fk(leg, angles), abs=1e-9)


def test_joints_stay_within_limits_under_random_targets():
    rng = np.random.default_rng(4)
    with AiboSim(seed=0) as sim:
        assert np.all((sim.joint_positions() >= JOINT_LIMITS[:, 0]) & (sim.joint_positions() <= JOINT_LIMITS[:, 1]))
        for _ in range(20):
            sim.set_joint_targets(rng.uniform(JOINT_LIMITS[:, 0], JOINT_LIMITS[:, 1]))
            sim.step(0.1)
            q = sim.joint_positions()
            # the solver lets a joint overshoot its stop by a little when slammed into it
            assert np.all(q >= JOINT_LIMITS[:, 0] - 0.035) and np.all(q <= JOINT_LIMITS[:, 1] + 0.035)


def test_commands_are_clipped_to_the_limits():
    with AiboSim(seed=0) as sim:
        applied = sim.set_joint_targets(np.full(18, 10.0))
        assert np.array_equal(applied, JOINT_LIMITS[:, 1])
        assert np.array_equal(sim.set_movement(5.0, -5.0), [0.15, -0.8])
