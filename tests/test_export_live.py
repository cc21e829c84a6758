"""What was taught, taken elsewhere, from real runs (real processes, Zenoh on loopback, PyBullet): the demo's
profile (the Aibo seeking the ball, camera recorded, arena reset) and the gym platform's Pendulum. Each run's
recording exported as a LeRobot dataset equals the recording (read back with pyarrow and av here, and with
LeRobot's own reader, lerobot-dataset, where a Python has it); each taught student, as a file, answers as
the live learner answered."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from bus_schema import ArenaReset, Command, Input, Reward, Spaces, decode
from rigs.harness import REPO, Probe, dogged, dogged_ok, free_port, stop
from services.cli import main
from services.demo.ballseek import start_ballseek
from services.experiments.ballseek import BALLSEEK_RATE_HZ
from services.experiments.wiring import wired_learner
from services.learners import load_student
from services.recording.reader import iter_samples, read_metadata, spaces_in
from services.recording.runs import load_run
from tests.test_supervisor import ps

pytestmark = pytest.mark.live

GYM_PROFILE = """
[profile]
name = "exportgym"
log_dir = "{tmp}/logs"
record_dir = "{tmp}/rec"

[services.platform]
box = "platform"
args = ["--platform", "gym", "--param", "env=Pendulum-v1", "--rate", "0"]
restart = "never"

[services.teacher]
box = "demonstrator"
args = ["--teacher", "pendulum"]

[services.learner]
box = "learner"
args = ["--learner", "gp"{params}]

[services.arbitrator]
box = "arbitrator"
"""


def snapshot(endpoint: str, path: Path) -> None:
    out = dogged_ok("snapshot", "learner", str(path), endpoint=endpoint)
    assert out.returncode == 0, out.stdout + out.stderr


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """The demo's profile (services/demo/ballseek.py) with an LWPR learner: a lesson with the pink ball, the
    student alone, a snapshot of its learner, the arena reset, the student again. The recording's folder and
    the snapshot's file."""
    run_dir = tmp_path_factory.mktemp("demo")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    run = start_ballseek(run_dir, endpoint, learner="lwpr")
    try:
        run.reset_arena(3, {"pink": [0.9, 0.3], "orange": None})
        run.teach(True)
        run.run_ticks(150, timeout=60)
        run.teach(False)
        run.run_ticks(30, timeout=60)
        snapshot(endpoint, run_dir / "live.student")
        run.run_ticks(60, timeout=60)
        run.reset_arena(4, {"pink": [0.8, -0.2]})
        run.run_ticks(60, timeout=60)
    finally:
        assert run.close() == 0
    [recording] = list((run_dir / "recordings").iterdir())
    return recording, run_dir / "live.student"


@pytest.fixture(scope="module")
def gym(tmp_path_factory):
    """Pendulum in lockstep with the wired GP: a lesson, the teacher off, the GP's fits caught up, a snapshot
    of the learner, the student alone. The recording's folder, the snapshot's file and the first tick after
    the snapshot."""
    tmp = tmp_path_factory.mktemp("gym")
    _, params = wired_learner("gym")
    profile = tmp / "exportgym.toml"
    params = "".join(f', "--param", "{k}={v}"' for k, v in params.items())
    profile.write_text(GYM_PROFILE.format(tmp=tmp, params=params))
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sup = dogged("up", str(profile), "--router", endpoint, "--quiet", log=tmp / "supervisor.log")
    probe = Probe(endpoint)
    inputs = probe.record("dl/main/input")
    try:
        probe.wait_for(lambda: (r := ps(endpoint)) and all(x["state"] == "ready" for x in r.values()), 90, "all ready")
        assert dogged_ok("teach", "on", endpoint=endpoint).returncode == 0
        probe.wait_for(lambda: probe.counter("arbitrator/arbitrator", "train_pairs") >= 500, 60, "500 pairs taught")
        assert dogged_ok("teach", "off", endpoint=endpoint).returncode == 0
        probe.wait_for_fresh_status("learner/learner")
        probe.wait_for(lambda: probe.counter("learner/learner", "upkeep_under_way", 1) == 0, 60, "the fits caught up")
        probe.wait_for_fresh_status("learner/learner")
        snapshot(endpoint, tmp / "live.student")
        after = max(tick_of(raw) for _, raw, _ in inputs[-20:])  # the newest tick once the snapshot is written
        probe.wait_for(lambda: tick_of(inputs[-1][1]) > after + 400, 60, "400 ticks of the student alone")
        assert dogged_ok("down", endpoint=endpoint).returncode == 0
        assert sup.wait(30) == 0
    finally:
        probe.close()
        stop(sup)
    [recording] = list((tmp / "rec").iterdir())
    return recording, tmp / "live.student", after + 1


def tick_of(raw: bytes) -> int:
    return decode(Input, raw, "dl/main/input").tick


def export(*args) -> None:
    assert main(["export", *map(str, args)]) == 0


def recorded_rows(recording) -> dict:
    """Every input that has a command, as the recording holds them (one platform run: a tick is an input)."""
    inputs, commands, resets, rewards = [], {}, [], {}
    keys = {"dl/main/input", "dl/main/command", "robot/aibo/arena", "dl/main/reward"}
    for sample in iter_samples(recording, keys):
        msg = sample.decoded()
        if isinstance(msg, Input):
            inputs.append((sample.log_ns, msg))
        elif isinstance(msg, Command):
            commands[msg.tick] = msg
        elif isinstance(msg, ArenaReset):
            resets.append(sample.log_ns)
        elif isinstance(msg, Reward):
            rewards[msg.tick] = msg
    rows = [(ns, i, commands[i.tick]) for ns, i in inputs if i.tick in commands]
    spaces = Spaces.from_dict(spaces_in(read_metadata(recording), "main"))
    first, last = rows[0][0], rows[-1][0]
    return {"x": np.array([i.x for _, i, _ in rows]), "y": np.array([c.y for _, _, c in rows]),
            "tick": [i.tick for _, i, _ in rows], "mode": [c.mode for _, _, c in rows],
            "source": [c.source for _, _, c in rows],
            "arena_episodes": 1 + sum(first < ns <= last for ns in resets),
            "gym_episodes": len({rewards[i.tick].episode for _, i, _ in rows if i.tick in rewards}),
            "reward": [rewards[i.tick].reward if i.tick in rewards else None for _, i, _ in rows],
            "names": {"observation.state": list(spaces.input.names), "action": list(spaces.output.names)}}


def same_floats(column: list, recorded: np.ndarray) -> bool:
    """A column equals the recorded values as float32 (a feature of one value is a plain column)."""
    return np.array_equal(np.array(column, np.float32).reshape(recorded.shape), recorded.astype(np.float32))


def check_dataset(root: Path, rows: dict, episodes: int, camera: tuple[int, int] | None) -> None:
    """The dataset's files as pyarrow and av read them equal the recording's rows."""
    info = json.loads((root / "meta/info.json").read_text())
    data = pq.read_table(root / "data/chunk-000/file-000.parquet").to_pydict()
    assert info["total_frames"] == len(rows["tick"]) and info["total_episodes"] == episodes
    assert same_floats(data["observation.state"], rows["x"]) and same_floats(data["action"], rows["y"])
    assert data["tick"] == rows["tick"] and data["mode"] == rows["mode"] and data["source"] == rows["source"]
    assert {"teacher", "student"} <= set(data["mode"])
    if "next.reward" in data:  # each step's reward, at the tick whose command earned it
        stepped = [i for i, r in enumerate(rows["reward"]) if r is not None]
        assert len(stepped) >= len(rows["tick"]) - 2
        assert np.array_equal(np.array(data["next.reward"], np.float32)[stepped],
                              np.array([rows["reward"][i] for i in stepped], np.float32))
    if camera:
        import av
        with av.open(str(root / "videos/observation.images.nose/chunk-000/file-000.mp4")) as video:
            sizes = [(f.width, f.height) for f in video.decode(video=0)]
        assert len(sizes) == len(rows["tick"]) and set(sizes) == {camera}


def lerobot_python() -> str | None:
    """A Python that has lerobot-dataset: $DOGGED_LEROBOT_PYTHON, else this one if it has it."""
    import importlib.util
    return os.environ.get("DOGGED_LEROBOT_PYTHON") or (sys.executable if importlib.util.find_spec("ledataset")
                                                       else None)


def loaded_by_lerobot(root: Path) -> dict:
    python = lerobot_python()
    if python is None:
        pytest.skip("no Python with lerobot-dataset here (it imports torch and torchvision, gigabytes): "
                    "`make lerobot-check` makes one and runs these tests with it, or set DOGGED_LEROBOT_PYTHON")
    out = subprocess.run([python, str(REPO / "tests/lerobot_check.py"), str(root)], capture_output=True, text=True,
                         timeout=600, env={**os.environ, "HF_HUB_OFFLINE": "1", "HF_DATASETS_OFFLINE": "1"})
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout)


def check_loaded(found: dict, rows: dict, episodes: int, camera: tuple[int, int] | None) -> None:
    """What LeRobotDataset read equals the recording's rows."""
    assert found["episodes"] == episodes and found["frames"] == len(rows["tick"])
    assert sum(found["episode_lengths"]) == len(rows["tick"])
    columns = found["columns"]
    assert same_floats(columns["observation.state"], rows["x"]) and same_floats(columns["action"], rows["y"])
    assert columns["tick"] == rows["tick"] and columns["mode"] == rows["mode"]
    assert columns["source"] == rows["source"]
    features = found["features"]
    assert {"observation.state", "action", "mode", "source", "confidence", "tick"} <= set(features)
    assert all(features[name]["names"] == names for name, names in rows["names"].items()), rows["names"]
    if camera:
        shown = found["video"]["shown"]
        assert len(shown) == 2 * episodes and all(shape == [3, camera[1], camera[0]] for shape, _ in shown.values())


@pytest.fixture(scope="module")
def exported(demo, gym, tmp_path_factory) -> dict:
    """Each run's recording exported as a LeRobot dataset: its folder, the recording's rows, its episodes and
    camera size."""
    found = {}
    for name, recording in (("demo", demo[0]), ("gym", gym[0])):
        root = tmp_path_factory.mktemp(f"{name}-dataset") / "ds"
        export(recording, "--lerobot", root)
        rows = recorded_rows(recording)
        episodes = rows["arena_episodes"] if name == "demo" else rows["gym_episodes"]
        found[name] = (root, rows, episodes, (208, 160) if name == "demo" else None)
    return found


def test_the_demos_dataset_is_its_recording(exported):
    root, rows, episodes, camera = exported["demo"]
    # the demo resets the arena before teaching (before or after the loop's first command, as it happens:
    # an episode then, or none) and once more mid-run: an episode more
    assert episodes in (2, 3)
    check_dataset(root, rows, episodes, camera)
    # the simulation's rate, in its own time (the demo runs in lockstep, faster)
    assert json.loads((root / "meta/info.json").read_text())["fps"] == BALLSEEK_RATE_HZ


def test_the_gym_runs_dataset_is_its_recording(exported):
    root, rows, episodes, camera = exported["gym"]
    assert episodes >= 4  # Pendulum's episodes are 200 steps
    check_dataset(root, rows, episodes, camera)
    assert "next.reward" in pq.read_schema(root / "data/chunk-000/file-000.parquet").names


@pytest.mark.parametrize("run", ["demo", "gym"])
def test_lerobots_own_reader_reads_the_recording_back(exported, run):
    root, rows, episodes, camera = exported[run]
    check_loaded(loaded_by_lerobot(root), rows, episodes, camera)


def answered_with(recording, learned: int, from_tick: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(inputs, outputs, confidences) of the live learner's recorded answers given having learned `learned`
    pairs, to inputs of `from_tick` on."""
    run = load_run(recording)
    inputs, answers = run.answered("learner")
    live = run.live["learner"]
    chosen = (live.learned[answers] == learned) & (run.ticks[inputs] >= from_tick)
    return run.x[inputs[chosen]], live.y[answers[chosen]], live.confidence[answers[chosen]]


def differences(student, x, y, confidence) -> tuple[float, float]:
    acted = [student.act(row) for row in x]
    return (float(np.max(np.abs(np.array([a[0] for a in acted]) - y))),
            float(np.max(np.abs(np.array([a[1] for a in acted]) - confidence))))


def test_lwpr_students_answer_as_the_live_learner_did(demo, tmp_path):
    """The student exported from the recording (retrained on its pairs) and the one `dogged snapshot` took
    from the running learner, on every input the live learner answered having learned the pairs they hold."""
    recording, snapped = demo
    export(recording, "--student", tmp_path / "exported.student")
    for path in (tmp_path / "exported.student", snapped):
        student = load_student(path)
        assert student.learner == "LWPR" and student.model.n_learned >= 100  # (150 ticks taught, loaded: fewer)
        x, y, confidence = answered_with(recording, student.model.n_learned)
        assert len(x) >= 30, f"{path.name}: {len(x)} answers having learned {student.model.n_learned} pairs"
        found = differences(student, x, y, confidence)
        assert found <= (1e-9, 1e-9), f"{path.name}: {found} on {len(x)} answers"


def test_a_gp_student_snapshotted_once_its_fits_caught_up_answers_as_the_live_one_after(gym):
    recording, snapped, after = gym
    student = load_student(snapped)
    assert student.learner == "GP" and student.model.n_learned >= 500
    x, y, confidence = answered_with(recording, student.model.n_learned, from_tick=after)
    assert len(x) >= 200, f"{len(x)} answers having learned {student.model.n_learned} pairs"
    found = differences(student, x, y, confidence)
    assert found <= (1e-9, 1e-9), f"{found} on {len(x)} answers"
    import gymnasium
    env = gymnasium.make("Pendulum-v1")
    observation, _ = env.reset(seed=0)
    for _ in range(20):  # the Gymnasium adapter drives the environment itself
        action = student.policy(observation)
        assert action.shape == (1,) and action.dtype == np.float32
        observation, *_ = env.step(action)
    env.close()
