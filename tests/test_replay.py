"""`dogged replay` on a recorded run written without a bus: the table, the plot, the schedule, quasi-batch,
and clear errors."""
import json
import subprocess
import sys

import numpy as np
import pytest

from rigs.harness import REPO
from rigs.recorded import write_point_run
from services.platforms.point import PointPlatform
from services.recording.runs import load_run
from services.replay.replay import as_served, catching_up, replay, schedule
from services.teachers import make_teacher

TICKS, TAUGHT = 600, 300  # 20 s at 30 Hz, the first half taught


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A point platform taught by the sine teacher for 10 s, then the student alone (a dumb one: zeros)."""
    point = PointPlatform(dims=2, seed=3)
    teacher = make_teacher("sine", point.spaces)
    return write_point_run(tmp_path_factory.mktemp("run"), point, TICKS,
                           lambda tick, x: (teacher(x)[0], None) if tick <= TAUGHT else None)


def test_the_schedule_follows_the_live_learner(run):
    recorded = load_run(run)
    plan = schedule(recorded, "l")
    assert plan[0] == 0 and plan[TAUGHT - 1] == TAUGHT - 1 and plan[-1] == TAUGHT
    assert np.array_equal(plan, schedule(recorded))  # here, as the pairs of earlier ticks say too


def test_quasi_batch_refits_once_the_teaching_span_ends(run):
    recorded = load_run(run)
    online, batch = replay(recorded, "knn"), replay(recorded, "knn", quasi_batch=True)
    assert batch.updates == TAUGHT and online.updates == TAUGHT
    assert np.all(batch.confidence[:TAUGHT] == batch.confidence[0])  # nothing learned while taught
    assert np.allclose(batch.y[TAUGHT + 1:], online.y[TAUGHT + 1:])  # one fit on every pair = online knn


@pytest.mark.live
def test_dogged_replay_prints_the_table_and_writes_the_plot(run, tmp_path):
    out = subprocess.run([sys.executable, "-m", "services.cli", "replay", str(run), "--learner", "lwpr", "--learner",
                          "knn:k=3", "--learner", "sogp", "--teacher", "sine", "--plot", str(tmp_path / "c.png"),
                          "--json", str(tmp_path / "f.json")], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    assert f"{TICKS} inputs over 20.0 s, {TAUGHT} training pairs" in out.stdout
    for row in ("live l", "lwpr", "knn:k=3", "sogp"):
        assert f"\n{row} " in out.stdout, out.stdout
    assert (tmp_path / "c.png").stat().st_size > 10_000
    rows = {r["spec"]: r for r in json.loads((tmp_path / "f.json").read_text())}
    assert rows["live l"]["student_error"] > 0.1  # the recorded student answered zeros
    assert rows["sogp"]["student_error"] < rows["live l"]["student_error"]
    assert rows["knn:k=3"]["size"] == TAUGHT


@pytest.mark.live
@pytest.mark.parametrize("args, message", [
    (["--learner", "nonsense"], "no learner 'nonsense'"),
    (["--learner", "lwpr:bogus=1"], "unknown hyper-parameter 'bogus'"),
    (["--teacher", "nobody"], "unknown teacher 'nobody'"),
    (["--instance", "other"], "no spaces of instance 'other'"),
])
def test_bad_arguments_are_clear_errors(run, args, message):
    out = subprocess.run([sys.executable, "-m", "services.cli", "replay", str(run), *args], cwd=REPO,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and message in out.stderr, out.stderr


@pytest.mark.live
def test_a_folder_without_recordings_is_a_clear_error(tmp_path):
    out = subprocess.run([sys.executable, "-m", "services.cli", "replay", str(tmp_path)], cwd=REPO,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and "no .mcap files" in out.stderr, out.stderr


def test_an_answer_whose_input_was_not_recorded_is_left_out(run):
    """(a restarted recorder can come in between an input and the learner's answer to it)"""
    recorded = load_run(run)
    keep = recorded.ticks != 100
    recorded.ticks, recorded.runs, recorded.t, recorded.x, recorded.modes = (
        recorded.ticks[keep], recorded.runs[keep], recorded.t[keep], recorded.x[keep], recorded.modes[keep])
    inputs, answers = recorded.answered("l")
    assert len(answers) == TICKS - 1 and 99 not in answers
    assert np.array_equal(recorded.ticks[inputs], recorded.live["l"].ticks[answers])


def test_ticks_the_live_learner_answered_while_catching_up_are_answered_unsure(tmp_path):
    point = PointPlatform(dims=2, seed=3)
    teacher = make_teacher("sine", point.spaces)
    folder = write_point_run(tmp_path, point, 60, lambda tick, x: (teacher(x)[0], None),
                             backlog=lambda tick: 3 if 20 <= tick < 23 else 0)
    recorded = load_run(folder)
    unsure = catching_up(recorded, "l")
    assert np.flatnonzero(unsure).tolist() == [19, 20, 21] and not catching_up(recorded, None).any()
    result = replay(recorded, "knn", plan=schedule(recorded, "l"))
    served = as_served(result, unsure)
    assert (served.confidence[unsure] == 0).all() and (result.confidence[unsure] > 0).all()
    assert np.array_equal(served.confidence[~unsure], result.confidence[~unsure])
    assert np.array_equal(served.y, result.y)


def test_a_file_with_the_spaces_and_no_inputs_replays_as_nothing_to_replay(tmp_path, capsys):
    """(a rotation that began as the platform stopped: its last frames and statuses, no input; the soak's quick run
    found one, which `dogged replay` refused)"""
    from bus_schema import Status, encode
    from services.recording.writer import RunWriter
    from services.replay.cli import replay_main
    writer = RunWriter(tmp_path, "recorder", 10**9, 3600.0)
    writer.add_metadata("spaces dl/main", {"spaces": json.dumps(PointPlatform(dims=2).spaces.to_dict())})
    writer.write("dl/main/status/recorder/recorder", Status, encode(Status("recorder", "recorder", 1, {}, {})), 1, 1)
    writer.close()
    assert replay_main([str(tmp_path), "--learner", "knn"]) == 0
    assert "none of its inputs recorded: nothing to replay" in capsys.readouterr().out
    assert replay_main([str(tmp_path), "--instance", "other"]) == 2  # another instance's: still a clear error
    assert "no spaces of instance 'other'" in capsys.readouterr().err
