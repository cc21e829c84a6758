"""The small parts two levels on one robot need: `dogged ps` grouped by instance, perception's
movement output, the learner a profile wires for one instance, the chain's easing."""
import argparse

import numpy as np
import pytest

from bus_schema import ControlReply, Spaces
from services.chaining import Easing
from services.boxes.perception import output_box
from services.experiments.wiring import wired_learner
from services.platforms.aibo.platform import JOINTS_BOX, LEGS_BOX, MOVE_BOX
from services.supervisor import commands


def row(name, box, instance):
    return {"name": name, "box": box, "pid": 1, "state": "ready", "restarts": 0, "uptime_s": 1.0, "exit": "",
            "rates": {}, "host": "here", "instance": instance}


def test_ps_groups_services_by_instance(monkeypatch, capsys):
    rows = [row("router", "router", ""), row("seek-learner", "learner", "seek"), row("aibo", "aibo", "body"),
            row("walk-learner", "learner", "walk"), row("seek-arbitrator", "arbitrator", "seek")]
    monkeypatch.setattr(commands, "_ask", lambda *a, **k: ControlReply(True, "", {"services": rows}))
    assert commands.ps(argparse.Namespace(json=False)) == 0
    lines = [line.split()[0] for line in capsys.readouterr().out.splitlines()[1:]]
    assert lines == ["the", "router", "instance", "seek-learner", "seek-arbitrator", "instance", "aibo",
                     "instance", "walk-learner"]


def test_ps_of_one_instance_has_no_headings(monkeypatch, capsys):
    rows = [row("learner", "learner", "main"), row("arbitrator", "arbitrator", "main")]
    monkeypatch.setattr(commands, "_ask", lambda *a, **k: ControlReply(True, "", {"services": rows}))
    commands.ps(argparse.Namespace(json=False))
    assert "instance" not in capsys.readouterr().out


def test_perception_outputs_the_movement_a_robot_offers_or_says_why_not():
    legs = Spaces(JOINTS_BOX, LEGS_BOX, {"movement": MOVE_BOX.to_dict()})
    assert output_box(legs, "movement", "aibo") == MOVE_BOX
    assert output_box(legs, "robot", "aibo") == LEGS_BOX
    with pytest.raises(ValueError, match="robot 'aibo' offers no movement command"):
        output_box(Spaces(JOINTS_BOX, JOINTS_BOX), "movement", "aibo")
    with pytest.raises(ValueError, match="malformed movement space"):
        output_box(Spaces(JOINTS_BOX, LEGS_BOX, {"movement": {"low": [1.0], "high": [0.0]}}), "movement", "aibo")


def test_a_profile_with_two_levels_wires_a_learner_per_instance():
    assert wired_learner("hierarchy", "walk")[0] == "knn"
    assert wired_learner("hierarchy", "seek") == ("gp", {"near": 0.2})
    with pytest.raises(ValueError, match="no learner for instance nowhere"):
        wired_learner("hierarchy", "nowhere")


def test_easing_reaches_the_target_over_its_time_and_zero_means_at_once():
    eased = Easing(np.zeros(2), 0.25)
    values = [eased.step([1.0, -1.0], 1 / 60) for _ in range(15)]  # a quarter second
    assert 0.6 < values[-1][0] < 0.65 and values[-1][1] == -values[-1][0]  # 1 - 1/e
    assert np.array_equal(Easing(np.zeros(2), 0.0).step([0.3, 0.4], 0.01), [0.3, 0.4])


def test_wander_asks_a_new_output_every_so_often_whatever_the_input():
    from services.teachers.wander import WanderTeacher
    now = [0.0]
    teacher = WanderTeacher(Spaces(JOINTS_BOX, MOVE_BOX), every=1.5, still=0.0, seed=3, clock=lambda: now[0])
    first, confidence = teacher(np.zeros(18))
    assert confidence == 1.0 and np.all(first >= MOVE_BOX.low) and np.all(first <= MOVE_BOX.high)
    now[0] = 1.4
    assert np.array_equal(teacher(np.ones(18))[0], first), "held for `every` seconds, whatever the input"
    now[0] = 1.6
    assert not np.array_equal(teacher(np.zeros(18))[0], first)
    with pytest.raises(ValueError, match="every must be a positive number"):
        WanderTeacher(Spaces(JOINTS_BOX, MOVE_BOX), every=0)
    with pytest.raises(ValueError, match="still must be a probability"):
        WanderTeacher(Spaces(JOINTS_BOX, MOVE_BOX), still=2)
