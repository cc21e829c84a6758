"""`dogged export` on a run written without a bus (the recorder's writer, real MCAP files): the dataset's
files read back with pyarrow and av equal the recording, episodes are cut where the run says, the camera's
video holds the recorded frames; the student file round-trips; bad inputs are clear errors."""
import contextlib
import io
import json
import pickle
import subprocess

import cv2
import numpy as np
import pyarrow.parquet as pq
import pytest

from bus_schema import ArenaReset, Command, Frame, Input, Proposal, Reward, TeachSwitch, TrainingPair, encode
from services.cli import main
from services.learners import StudentFileError, load_student, make_learner, save_student
from services.platforms.point import PointPlatform
from services.recording.writer import RunWriter
from services.teachers import make_teacher

TICKS, TAUGHT, RESTART_AT = 600, 300, 500  # the platform restarts after tick 500: its ticks count from 1 again
RESETS = (200, 400)  # arena resets before these ticks
GYM_STEPS = 100      # a Gymnasium-like episode every 100 steps
SIZE = (48, 32)      # the camera's frames (width, height)


def camera_image(i: int) -> np.ndarray:
    """Frame i: a brightness of its own (so a frame out of place shows) and a bar that moves."""
    image = np.full((SIZE[1], SIZE[0], 3), 40 + (i * 7) % 180, np.uint8)
    image[:, (i % SIZE[0]):(i % SIZE[0]) + 4] = 255
    return image


def write_run(folder, camera=True, rewards=True, resets=RESETS) -> dict:
    """A point platform taught by the sine teacher for TAUGHT ticks, then the student (zeros); what was
    written, by row."""
    point = PointPlatform(dims=2, seed=3)
    teacher = make_teacher("sine", point.spaces)
    writer = RunWriter(folder, "recorder", 10**9, 3600.0)
    writer.add_metadata("spaces dl/main", {"spaces": json.dumps(point.spaces.to_dict())})
    writer.add_metadata("run", {"instances": "main", "robots": "sim"})
    written = {"x": [], "y": [], "tick": [], "mode": [], "frame": []}
    seq = 0
    for i in range(1, TICKS + 1):
        tick = i if i <= RESTART_AT else i - RESTART_AT
        x, stamp, ns = point.observe(), 1000 + i / 30, i * 33_333_333
        if i in resets:
            writer.write("robot/sim/arena", ArenaReset, encode(ArenaReset(i, {})), ns - 1000, ns - 1000)
        if camera:
            jpeg = cv2.imencode(".jpg", camera_image(i), [cv2.IMWRITE_JPEG_QUALITY, 95])[1].tobytes()
            writer.write("robot/sim/camera", Frame, encode(Frame(tick, stamp, i / 30, *SIZE, jpeg)), ns - 10, ns - 10)
        writer.write("dl/main/input", Input, encode(Input(tick, stamp, x)), ns, ns)
        writer.write("dl/main/proposal/learner/l", Proposal,
                     encode(Proposal(tick, "learner/l", np.zeros(2), 0.1, learned=seq)), ns + 1, ns + 1)
        taught = i <= TAUGHT
        y = teacher(x)[0] if taught else np.zeros(2)
        mode, source = ("teacher", "teacher/sine") if taught else ("student", "learner/l")
        writer.write("dl/main/command", Command, encode(Command(tick, stamp, y, mode, source, 0.5)), ns + 2, ns + 2)
        if taught:
            seq += 1
            writer.write("dl/main/train", TrainingPair, encode(TrainingPair("e", seq, tick, x, y, "teacher/sine")),
                         ns + 3, ns + 3)
        if rewards:
            step = (i - 1) % GYM_STEPS + 1 if i <= RESTART_AT else tick
            episode = (i - 1) // GYM_STEPS if i <= RESTART_AT else 0
            writer.write("dl/main/reward", Reward, encode(Reward(tick, episode, step, -float(i), 0.0,
                                                                 step == GYM_STEPS)), ns + 4, ns + 4)
        for name, value in (("x", x), ("y", y), ("tick", tick), ("mode", mode), ("frame", i)):
            written[name].append(value)
        point.step(y, 1 / 30)
    writer.close()
    return {k: np.array(v) for k, v in written.items()}


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    folder = tmp_path_factory.mktemp("run")
    return folder, write_run(folder)


def export(*args) -> subprocess.CompletedProcess:
    """`dogged export` in this process (quick); what it printed and its exit code, as a subprocess's."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(["export", *map(str, args)])
        except SystemExit as exit:  # argparse's errors
            code = exit.code
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


def read_dataset(root) -> tuple[dict, dict, dict]:
    """(info, the data's columns, the episodes' columns) as pyarrow reads them."""
    info = json.loads((root / "meta/info.json").read_text())
    data = pq.read_table(root / "data/chunk-000/file-000.parquet").to_pydict()
    episodes = pq.read_table(root / "meta/episodes/chunk-000/file-000.parquet").to_pydict()
    return info, data, episodes


def test_the_dataset_holds_every_tick_as_recorded_and_the_camera_as_video(recorded, tmp_path):
    folder, written = recorded
    out = export(folder, "--lerobot", tmp_path / "ds", "--episode-by", "arena")
    assert out.returncode == 0, out.stderr
    assert f"{TICKS} frames in 4 episodes (by arena) at 30 fps, with the camera" in out.stdout, out.stdout
    info, data, episodes = read_dataset(tmp_path / "ds")
    assert info["codebase_version"] == "v3.0" and info["total_frames"] == TICKS and info["fps"] == 30
    assert info["features"]["observation.state"]["names"] == ["stimulus0", "stimulus1", "position0", "position1"]
    assert info["features"]["action"]["names"] == ["target0", "target1"]
    assert np.array_equal(np.array(data["observation.state"], np.float32), written["x"].astype(np.float32))
    assert np.array_equal(np.array(data["action"], np.float32), written["y"].astype(np.float32))
    assert data["tick"] == written["tick"].tolist() and data["mode"] == written["mode"].tolist()
    assert data["source"][0] == "teacher/sine" and data["source"][-1] == "learner/l"
    # restarts and arena resets begin episodes: before 200, 200..399, 400..500, the restarted platform's
    assert episodes["length"] == [199, 200, 101, TICKS - RESTART_AT]
    assert episodes["dataset_from_index"] == [0, 199, 399, RESTART_AT]
    assert np.allclose(data["timestamp"], np.array(data["frame_index"]) / 30, atol=1e-6)
    assert data["frame_index"][199] == 0 and data["episode_index"][199] == 1
    assert info["features"]["observation.images.nose"]["shape"] == [SIZE[1], SIZE[0], 3]
    stats = json.loads((tmp_path / "ds/meta/stats.json").read_text())
    assert np.allclose(stats["action"]["mean"], written["y"].astype(np.float32).mean(0), atol=1e-6)
    camera = np.array(stats["observation.images.nose"]["mean"])  # LeRobot's: per channel, in [0, 1]
    recorded = np.mean([camera_image(i).reshape(-1, 3).mean(0) for i in written["frame"]], 0) / 255
    assert camera.shape == (3, 1, 1) and np.allclose(camera.ravel(), recorded, atol=0.01)
    import av
    with av.open(str(tmp_path / "ds/videos/observation.images.nose/chunk-000/file-000.mp4")) as video:
        images = [f.to_ndarray(format="rgb24") for f in video.decode(video=0)]
    assert len(images) == TICKS and images[0].shape == (SIZE[1], SIZE[0], 3)
    brightness = np.array([image[:, 20:28].mean() for image in images])  # (off the bar, mostly)
    expected = np.array([camera_image(i)[:, 20:28].mean() for i in written["frame"]])
    assert np.mean(np.abs(brightness - expected)) < 6, "the video's frames are not the recorded ones, in order"


@pytest.mark.parametrize("by, lengths", [
    ("run", [RESTART_AT, TICKS - RESTART_AT]),
    ("teaching", [TAUGHT, RESTART_AT - TAUGHT, TICKS - RESTART_AT]),
    ("gym", [GYM_STEPS] * (RESTART_AT // GYM_STEPS) + [TICKS - RESTART_AT]),
    ("auto", [GYM_STEPS] * (RESTART_AT // GYM_STEPS) + [TICKS - RESTART_AT]),
])
def test_episodes_are_cut_where_the_run_says(recorded, tmp_path, by, lengths):
    folder, _ = recorded
    out = export(folder, "--lerobot", tmp_path / "ds", "--episode-by", by, "--no-video")
    assert out.returncode == 0, out.stderr
    info, data, episodes = read_dataset(tmp_path / "ds")
    assert episodes["length"] == lengths and info["total_episodes"] == len(lengths)
    assert info["video_path"] is None and "observation.images.nose" not in info["features"]
    if by in ("gym", "auto"):
        assert data["next.reward"][:3] == [-1.0, -2.0, -3.0] and data["next.done"][GYM_STEPS - 1]


def test_the_student_file_is_the_learner_taught_every_recorded_pair(recorded, tmp_path):
    folder, written = recorded
    out = export(folder, "--student", tmp_path / "s.student", "--learner", "lwpr")
    assert out.returncode == 0, out.stderr
    assert f"a LWPR student, {TAUGHT} pairs learned" in out.stdout
    student = load_student(tmp_path / "s.student")
    same = make_learner("lwpr", 4, 2)
    for x, y in zip(written["x"][:TAUGHT], written["y"][:TAUGHT]):
        same.learn_one(x, y)
    for x in written["x"][::50]:
        y, confidence = student.act(x)
        p = same.predict_one(x)
        assert np.array_equal(y, np.clip(p.y, -1, 1)) and confidence == p.confidence


def test_an_export_cut_short_leaves_no_dataset(recorded, tmp_path, monkeypatch):
    import services.export.lerobot as lerobot

    def failing(*args):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(lerobot, "encode_video", failing)
    out = export(recorded[0], "--lerobot", tmp_path / "ds")
    assert out.returncode == 2 and "No space left on device" in out.stderr, out.stderr
    assert list(tmp_path.iterdir()) == []  # neither the dataset nor its partial folder


def test_a_frame_that_does_not_decode_shows_the_last_one_again(tmp_path):
    point = PointPlatform(dims=2)
    writer = RunWriter(tmp_path / "run", "recorder", 10**9, 3600.0)
    writer.add_metadata("spaces dl/main", {"spaces": json.dumps(point.spaces.to_dict())})
    writer.add_metadata("run", {"instances": "main", "robots": "sim"})
    for tick in range(1, 11):
        jpeg = cv2.imencode(".jpg", camera_image(tick))[1].tobytes() if tick != 5 else b"\xff\xd8 not a JPEG"
        writer.write("robot/sim/camera", Frame, encode(Frame(tick, 1000.0 + tick, 0.0, *SIZE, jpeg)), tick, tick)
        writer.write("dl/main/input", Input, encode(Input(tick, 1000.0 + tick, point.observe())), tick + 1, tick + 1)
        writer.write("dl/main/command", Command, encode(Command(tick, 1000.0 + tick, np.zeros(2), "student", "l", 0.5)),
                     tick + 2, tick + 2)
    writer.close()
    out = export(tmp_path / "run", "--lerobot", tmp_path / "ds")
    assert out.returncode == 0 and "10 frames in 1 episode (by run) at 1 fps, with the camera" in out.stdout, out


def test_a_student_file_is_data_and_says_what_is_wrong_with_one_that_is_not(tmp_path):
    point = PointPlatform(dims=2)
    model = make_learner("knn", 4, 2)
    model.learn_one(np.full(4, 0.5), np.array([3.0, -0.25]))
    path = save_student(tmp_path / "k.student", model, point.spaces, "test")
    student = load_student(path)
    y, confidence = student.act(np.full(4, 0.5))
    assert np.array_equal(y, [1.0, -0.25]) and 0 <= confidence <= 1  # clipped to the output space, as live
    assert student.policy(np.full((2, 2), 0.5)).dtype == np.float32  # an observation of any shape, flattened
    (tmp_path / "p.student").write_bytes(pickle.dumps(model))
    (tmp_path / "cut.student").write_bytes(path.read_bytes()[:-20])
    for name, message in (("p", "not a student file"), ("cut", "not a student file"), ("none", "no such file")):
        with pytest.raises(StudentFileError, match=message):
            load_student(tmp_path / f"{name}.student")


def test_a_discrete_student_acts_with_the_index_of_its_largest_output(tmp_path):
    from bus_schema.spaces import Box, Spaces
    spaces = Spaces(Box.uniform(2, -1, 1), Box.uniform(3, 0, 1), {"platform": "gym", "choice": "largest"})
    model = make_learner("knn", 2, 3)
    model.learn_one(np.zeros(2), np.array([0.0, 0.0, 1.0]))
    student = load_student(save_student(tmp_path / "d.student", model, spaces))
    assert student.policy(np.zeros(2)) == 2


@pytest.fixture(scope="module")
def broken(tmp_path_factory, recorded) -> dict:
    """Runs that cannot be exported, by name: no files, no ticks, no commands, no rewards."""
    made = {name: tmp_path_factory.mktemp(name) for name in ("empty", "ticksless", "commandless", "rewardless")}
    writer = RunWriter(made["ticksless"], "recorder", 10**9, 3600.0)
    writer.add_metadata("spaces dl/main", {"spaces": json.dumps(PointPlatform(dims=2).spaces.to_dict())})
    writer.write("dl/main/teach", TeachSwitch, encode(TeachSwitch("", True)), 1, 1)  # a sample, but no input
    writer.close()
    point = PointPlatform(dims=2)
    writer = RunWriter(made["commandless"], "recorder", 10**9, 3600.0)  # a platform alone
    writer.add_metadata("spaces dl/main", {"spaces": json.dumps(point.spaces.to_dict())})
    for tick in range(1, 20):
        writer.write("dl/main/input", Input, encode(Input(tick, 1000 + tick / 30, point.observe())), tick, tick)
    writer.close()
    write_run(made["rewardless"], camera=False, rewards=False, resets=())
    return {**made, "run": recorded[0]}


@pytest.mark.parametrize("args, message", [
    (["{missing}", "--lerobot", "{tmp}/ds"], "no such recording"),
    (["{empty}", "--lerobot", "{tmp}/ds"], "no .mcap files"),
    (["{ticksless}", "--lerobot", "{tmp}/ds"], "no ticks of instance 'main' recorded"),
    (["{commandless}", "--lerobot", "{tmp}/ds"], "no command for any of them"),
    (["{run}", "--lerobot", "{tmp}"], "already exists"),
    (["{run}", "--lerobot", "{tmp}/ds", "--instance", "other"], "no spaces of instance 'other'"),
    (["{rewardless}", "--lerobot", "{tmp}/ds", "--episode-by", "gym"], "the run has no Gymnasium episodes"),
    (["{rewardless}", "--lerobot", "{tmp}/ds", "--episode-by", "arena"], "no arena reset recorded"),
    (["{run}", "--student", "{tmp}/s", "--learner", "nonsense"], "no learner 'nonsense'; learners: gp"),
    (["{run}", "--student", "{tmp}/s", "--live", "nobody"], "no live learner 'nobody'"),
    (["{ticksless}", "--student", "{tmp}/s"], "the spaces of instance 'main' but none of its inputs recorded"),
    (["{commandless}", "--student", "{tmp}/s", "--learner", "lwpr"], "no training pairs recorded"),
    (["{run}"], "nothing to do"),
])
def test_bad_inputs_are_clear_errors(broken, tmp_path, args, message):
    names = {**broken, "missing": tmp_path / "nowhere", "tmp": tmp_path}
    out = export(*[a.format(**names) for a in args])
    assert out.returncode == 2 and message in out.stderr, out.stderr
