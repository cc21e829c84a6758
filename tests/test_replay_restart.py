"""A recorded run over a platform restart, written as the recorder writes it: the platform counts its ticks
from 1 again while the arbitrator and the learner go on. Every input of both stretches is kept, each live
answer is paired with its own input (a replay of the live learner reproduces every answer), the teacher's
pairs stay at their own inputs, and `dogged play`'s platform plays every input at the recorded rate."""
import json

import numpy as np
import pytest

from bus_schema import Command, Input, Proposal, TrainingPair, encode
from services.learners import make_learner
from services.platforms.point import PointPlatform
from services.recording.platform import RecordedPlatform
from services.recording.runs import load_run
from services.recording.writer import RunWriter
from services.replay.replay import replay, schedule
from services.teachers import make_teacher

STRETCHES = (240, 180)  # ticks before the restart, and after it
RESTART_S = 3.0         # the platform's downtime
DROPPED = (1, 120)      # (stretch, tick) of an input the recorder did not get (its answer was recorded)
HZ = 30
START = 1.7e9           # the wall clock (s) at the first tick: the platform's stamps, the recorder's log times


def taught(stretch: int, tick: int) -> bool:
    return tick <= 80 or tick > 160 if stretch == 0 else tick <= 90


class Loop:
    """A point platform, the sine teacher, a live knn learner and the arbitrator's pairs, into a recording."""

    def __init__(self, folder):
        self.point = PointPlatform(dims=2, seed=3)
        self.writer = RunWriter(folder, "recorder", 10**9, 3600.0)
        self.writer.add_metadata("spaces dl/main", {"spaces": json.dumps(self.point.spaces.to_dict())})
        self.learner = make_learner("knn", 4, 2, seed=0)
        self.teacher = make_teacher("sine", self.point.spaces)
        self.clock, self.seq = START, 0
        self.inputs, self.answers, self.pairs = [], [], []  # as the loop saw them, per (stretch, tick)

    def write(self, key: str, cls, msg, after_s: float = 0.0) -> None:
        ns = int((self.clock + after_s) * 1e9)
        self.writer.write(key, cls, encode(msg), ns, ns)

    def tick(self, stretch: int, tick: int) -> None:
        x, stamp = self.point.observe(), self.clock
        answer = self.learner.predict_one(x)
        proposal = Proposal(tick, "learner/l", self.point.spaces.output.clip(answer.y), answer.confidence,
                            learned=self.seq)
        first = tick == 1  # the restarted platform's first answer reaches the recorder before its input
        self.write("dl/main/proposal/learner/l", Proposal, proposal, after_s=-1e-3 if first else 1e-3)
        if (stretch, tick) != DROPPED:
            self.write("dl/main/input", Input, Input(tick, stamp, x))
            self.inputs.append((stretch, tick, x))
        self.answers.append((stretch, tick, proposal.y))
        y = self.teacher(x)[0] if taught(stretch, tick) else proposal.y
        mode = "teacher" if taught(stretch, tick) else "student"
        self.write("dl/main/command", Command, Command(tick, stamp, y, mode, "t", 1.0), after_s=2e-3)
        if taught(stretch, tick):
            self.seq += 1
            self.write("dl/main/train", TrainingPair, TrainingPair("e", self.seq, tick, x, y, "teacher/t"),
                       after_s=3e-3)
            self.learner.learn_one(x, y)
            self.pairs.append((stretch, tick, y))
        self.point.step(y, 1 / HZ)
        self.clock += 1 / HZ

    def restart_platform(self) -> None:
        self.point = PointPlatform(dims=2, seed=4)
        self.clock += RESTART_S


@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    loop = Loop(tmp_path_factory.mktemp("run"))
    for stretch, ticks in enumerate(STRETCHES):
        if stretch:
            loop.restart_platform()
        for tick in range(1, ticks + 1):
            loop.tick(stretch, tick)
    loop.writer.close()
    loop.folder = loop.writer.folder
    return loop


def test_every_input_of_both_stretches_is_kept(loop):
    run = load_run(loop.folder)
    assert len(run.ticks) == sum(STRETCHES) - 1  # all but the input the recorder did not get
    assert [(int(r), int(t)) for r, t in zip(run.runs, run.ticks)] == [(s, t) for s, t, _ in loop.inputs]
    assert np.array_equal(run.x, np.array([x for _, _, x in loop.inputs]))
    assert np.all(np.diff(run.t) > 0)  # the stamps' order, across the restart
    assert (run.modes == "teacher").sum() == len(loop.pairs) and (run.modes == "").sum() == 0


def test_each_live_answer_is_paired_with_its_own_input(loop):
    run = load_run(loop.folder)
    assert len(run.live["l"].ticks) == sum(STRETCHES)
    inputs, answers = run.answered("l")
    assert len(answers) == sum(STRETCHES) - 1  # the answer to the dropped input is left out, not paired
    assert [(int(run.runs[i]), int(run.ticks[i])) for i in inputs] == [(s, t) for s, t, _ in loop.inputs]
    result = replay(run, "knn", plan=schedule(run, "l"))
    assert np.max(np.abs(result.y[inputs] - run.live["l"].y[answers])) == 0.0
    assert np.max(np.abs(result.confidence[inputs] - run.live["l"].confidence[answers])) == 0.0


def test_the_teachers_pairs_stay_at_their_own_inputs(loop):
    run = load_run(loop.folder)
    assert len(run.pair_ticks) == len(loop.pairs) == 250
    assert [(int(r), int(t)) for r, t in zip(run.pair_runs, run.pair_ticks)] == [(s, t) for s, t, _ in loop.pairs]
    taught_y = run.taught_at_ticks()
    expected = {(s, t): y for s, t, y in loop.pairs}
    for i, (r, t) in enumerate(zip(run.runs, run.ticks)):
        y = expected.get((int(r), int(t)))
        assert np.array_equal(taught_y[i], y) if y is not None else np.isnan(taught_y[i]).all()
    assert run.pairs_before()[STRETCHES[0]] == 160  # the restarted platform's first input: every earlier pair


def test_dogged_play_plays_both_stretches_at_the_recorded_rate(loop):
    platform = RecordedPlatform(str(loop.folder))
    assert len(platform) == sum(STRETCHES) - 1
    assert np.array_equal(platform.x, np.array([x for _, _, x in loop.inputs]))
    assert platform.recorded_hz == pytest.approx(HZ, rel=1e-4)


def test_a_platform_failing_sooner_after_each_restart_keeps_its_rate(tmp_path):
    """Runs of 6, 5, ... 1 ticks: every tick's last recording is from a later run than the next tick's."""
    writer = RunWriter(tmp_path, "recorder", 10**9, 3600.0)
    writer.add_metadata("spaces dl/main", {"spaces": json.dumps(PointPlatform(dims=2).spaces.to_dict())})
    clock = START
    for length in range(6, 0, -1):
        for tick in range(1, length + 1):
            writer.write("dl/main/input", Input, encode(Input(tick, clock, np.zeros(4))), int(clock * 1e9),
                         int(clock * 1e9))
            clock += 1 / HZ
        clock += RESTART_S
    writer.close()
    platform = RecordedPlatform(str(tmp_path))
    assert len(platform) == 21 and platform.recorded_hz == pytest.approx(HZ, rel=1e-4)
