"""Every command leaves the learner and the arbitrator inside the output space (a fake bus records
what they publish): a learner's answer, or a teacher's, outside it is clipped and counted."""
import numpy as np
import zenoh

from bus_schema import Command, Input, InstanceKeys, Proposal, TrainingPair, decode, encode
from bus_schema.spaces import Box, Spaces
from services.arbitration.strategies import TeacherFirst
from services.boxes.arbitrator import Arbitrator
from services.boxes.learner import LearnerNode
from services.learners.base import Prediction
from services.pairlog import PairLog
from tests.fakebus import fake_box

KEYS = InstanceKeys("main")
SPACES = Spaces(Box((-1.0, -1.0), (1.0, 1.0)), Box((-0.5, 0.0), (0.5, 2.0)))


def test_the_arbitrator_clips_a_teachers_command_and_what_it_teaches():
    box = fake_box("arbitrator")
    arb = Arbitrator(box, SPACES, TeacherFirst(), 0.02, None, "teacher", 16)
    arb.members.update(KEYS.alive("teaching", "wild"), zenoh.SampleKind.PUT)
    arb.on_input(KEYS.input, encode(Input(1, 0.0, np.zeros(2))), 0.0)
    arb.on_proposal(f"{KEYS.prefix}/proposal/teacher/wild",
                    encode(Proposal(1, "teacher/wild", np.array([3.0, -7.0]), 1.0)), 0.001)
    arb.decide_ready(0.001)
    command = decode(Command, box.session.on(KEYS.command)[-1], KEYS.command)
    pair = decode(TrainingPair, box.session.on(KEYS.train)[-1], KEYS.train)
    assert command.y.tolist() == [0.5, 0.0] and pair.y.tolist() == [0.5, 0.0]
    assert arb.counts["clipped_commands"] == 1


class Wild:
    """A model whose answer is outside the robot's output space."""
    n_in, n_out, n_learned = 2, 2, 0

    def predict_one(self, x):
        return Prediction(np.array([-4.0, 1.0]), 0.9)


def test_the_learner_clips_its_proposal_and_counts_it():
    box = fake_box("learner", "student")
    node = LearnerNode(box, Wild(), PairLog(2, 2), SPACES.output)
    node.answer(Input(7, 0.0, np.zeros(2)))
    proposal = decode(Proposal, box.session.on(KEYS.proposal("learner", "student"))[-1], "proposal")
    assert proposal.y.tolist() == [-0.5, 1.0] and proposal.tick == 7
    assert node.counts["clipped"] == 1
