"""A per-output learner replayed side by side in processes (services/replay/side_by_side.py) answers as in one
process, to the last bit: a recorded run written to a real file, taught by a full teacher, then by two partial
ones (one output each), one output held still throughout."""
import subprocess
import sys

import numpy as np
import pytest

from rigs.harness import REPO
from rigs.recorded import write_point_run
from services.learners import make_learner
from services.platforms.point import PointPlatform
from services.recording.runs import load_run
from services.replay.replay import replay, schedule
from services.replay.side_by_side import Job, ReplayWorkers, output_bins, replay_any, replay_side_by_side

SPEC = "per-output:base=gp"
HELD = 0.25  # output 2's value, taught all along


def lesson(tick: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None] | None:
    """Ticks 1-150 a full teacher; 151-250 one teaching output 0 only, 251-300 output 1 only (the rest of their
    pairs a guess, masked out); then the student."""
    if tick > 300:
        return None
    y = np.array([np.sin(2 * x[0]) * 0.8, np.cos(x[1] + x[3]) * 0.8 - 0.2, HELD])
    if tick <= 150:
        return y, None
    guess = np.array([0.9, -0.9, -0.6])
    if tick <= 250:
        return np.where([1, 0, 0], y, guess), np.array([1.0, 0.0, 0.0])
    return np.where([0, 1, 0], y, guess), np.array([0.0, 1.0, 0.0])


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return write_point_run(tmp_path_factory.mktemp("run"), PointPlatform(dims=3, seed=4), 400, lesson)


def test_each_output_taught_values_is_a_bin_and_the_held_ones_one_more(run):
    recorded = load_run(run)
    assert output_bins(recorded, SPEC) == [[0], [1], [2]]
    assert output_bins(recorded, SPEC, most=2) == [[0, 2], [1]]  # past the cap, dealt out in turn
    assert output_bins(recorded, "gp") == []  # not per-output: one process
    held = load_run(run)
    held.pair_y[:, 1] = HELD  # output 1 held too: still two bins, [0] and the held ones
    assert output_bins(held, SPEC) == [[0], [1, 2]]
    held.pair_y[:, 0] = HELD
    assert output_bins(held, SPEC) == []  # one bin: nothing to share out


@pytest.mark.live
def test_side_by_side_answers_as_one_process_to_the_last_bit(run):
    recorded = load_run(run)
    plan = schedule(recorded, "l")
    one = replay(recorded, SPEC, 0, plan)
    bins = output_bins(recorded, SPEC)
    with ReplayWorkers(len(bins), SPEC, recorded.spaces.input.dims, recorded.spaces.output.dims) as workers:
        side = replay_side_by_side(recorded, SPEC, 0, plan, workers, bins)
        again = replay_side_by_side(recorded, SPEC, 0, plan, workers, bins)  # the processes serve job after job
    assert one.updates == side.updates == 300
    assert np.array_equal(side.y, one.y) and np.array_equal(side.confidence, one.confidence)
    assert np.array_equal(again.y, one.y) and np.array_equal(again.confidence, one.confidence)
    assert side.size == one.size > 0
    assert np.abs(one.y[-100:, 2] - HELD).max() < 1e-9  # it learned: the held output is held
    assert one.confidence[-1] > 0.25  # and the taught ones, surely
    assert np.array_equal(replay_any(recorded, SPEC, 0, plan).y, one.y)


@pytest.mark.live
def test_a_failing_job_is_a_clear_error_and_the_processes_end(run):
    recorded = load_run(run)
    plan = schedule(recorded, "l")
    workers = ReplayWorkers(1, SPEC, recorded.spaces.input.dims, recorded.spaces.output.dims)
    processes = list(workers._processes)
    with workers, pytest.raises(RuntimeError, match="a replay process failed: IndexError"):
        workers.run([Job(0, [7], recorded.x, recorded.pair_x, recorded.pair_y, recorded.pair_mask, plan,
                         recorded.pair_sources)])
    with pytest.raises(ValueError, match="2 jobs for 0 processes"):
        workers.run([None, None])
    for process in processes:
        assert not process.is_alive()


def test_per_output_answers_are_what_predict_one_gathers():
    model = make_learner("per-output", 2, 3, base="gp")
    rng = np.random.default_rng(0)
    for x in rng.uniform(-1, 1, (40, 2)):
        model.learn_one(x, np.array([x[0], 0.5, 0.5]), mask=np.array([1.0, 1.0, 1.0]))
    for x in rng.uniform(-1, 1, (20, 2)):
        model.learn_one(x, np.array([0.0, x[1], 0.0]), mask=np.array([0.0, 1.0, 0.0]))
    query = np.array([0.3, -0.2])
    y, confidence = model.answers(query)
    p = model.predict_one(query)
    assert np.array_equal(y, p.y) and p.confidence == confidence.min()
    only, sure = model.answers(query, [1])
    assert only[1] == y[1] and sure[1] == confidence[1] and np.isnan(sure[[0, 2]]).all() and not only[[0, 2]].any()
    assert model.size_of(range(3)) == model.size == model.size_of([0]) + model.size_of([1, 2])
    assert np.isnan(make_learner("per-output", 2, 3, base="gp").answers(query)[1]).all()


@pytest.mark.live
def test_dogged_replay_runs_a_per_output_learner_side_by_side(run):
    done = subprocess.run([sys.executable, "-m", "services.cli", "replay", str(run), "--learner", SPEC,
                           "--learner", "knn"], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "per-output:base=gp" in done.stdout and "replayed in" in done.stdout
