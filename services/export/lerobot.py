"""A recorded run as a LeRobot dataset (format v3.0, as LeRobot's LeRobotDataset reads it):

    meta/info.json                      fps, features (names from the spaces), totals, paths
    meta/tasks.parquet                  the task (one: what the teacher taught)
    meta/episodes/chunk-000/file-000.parquet   per episode: its frames' and video's place
    meta/stats.json                     min, max, mean, std, count, quantiles of each feature but strings
    data/chunk-000/file-000.parquet     one row per tick
    videos/observation.images.nose/chunk-000/file-000.mp4   the camera, where one was recorded

A frame is a tick: `observation.state` the platform's input, `action` the command, and who drove: `mode`
(teacher, student or unsure: the robot asked), `source` (teacher/<name>, learner/<name>, ...) and
`confidence`; `tick` names the recorded tick; a Gymnasium run adds `next.reward` and `next.done`. Numbers
are float32, LeRobot's; `timestamp` is frame_index / fps, as LeRobot writes it.
"""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np

from services.export.episodes import chosen, episode_index, episode_starts
from services.export.ticks import ExportError, TickTable
from services.export.video import encode_video, even_size, image_stats

CODEBASE_VERSION = "v3.0"
CHUNK_FILE = "chunk-{chunk_index:03d}/file-{file_index:03d}"
DATA_PATH = "data/" + CHUNK_FILE + ".parquet"
VIDEO_PATH = "videos/{video_key}/" + CHUNK_FILE + ".mp4"
EPISODES_PATH = "meta/episodes/" + CHUNK_FILE + ".parquet"
CAMERA_KEY = "observation.images.nose"  # the Aibo's camera is in its nose
QUANTILES = {"q01": 0.01, "q10": 0.10, "q50": 0.50, "q90": 0.90, "q99": 0.99}  # LeRobot's, by its names


def needs_export_extra(video: bool = False):
    """pyarrow (and av, for the camera), or an ExportError saying how to install them."""
    try:
        import pyarrow
        import pyarrow.parquet  # noqa: F401
        if video:
            import av  # noqa: F401
    except ImportError as err:
        raise ExportError(f"exporting a LeRobot dataset needs pyarrow and av ({err}): pip install "
                          "'dogged[export]'") from None
    return pyarrow


def fps_of(table: TickTable) -> int:
    """The platform's rate as recorded: the median interval between ticks within each run, in the robot's
    simulated time where its clock was recorded (a simulation in lockstep runs faster than its own time),
    else by the platform's stamps."""
    times = table.stamps if table.sim_times is None else table.sim_times
    steps = np.diff(times)[table.runs[1:] == table.runs[:-1]]
    steps = steps[steps > 0]  # (an arena reset may start the simulated time again)
    return max(1, round(1.0 / float(np.median(steps)))) if len(steps) else 1


def task_of(table: TickTable) -> str:
    extra = table.spaces.extra
    what = extra.get("env") or table.robot or extra.get("platform") or "a platform"
    return f"what the teacher taught on {what} (dogged instance {table.instance})"


def features(table: TickTable, video_size: tuple[int, int] | None, fps: int) -> dict:
    spaces = table.spaces
    found = {
        "observation.state": {"dtype": "float32", "shape": [spaces.input.dims],
                              "names": list(spaces.input.names) or None},
        "action": {"dtype": "float32", "shape": [spaces.output.dims], "names": list(spaces.output.names) or None},
        "confidence": {"dtype": "float32", "shape": [1], "names": None},
        "mode": {"dtype": "string", "shape": [1], "names": None},
        "source": {"dtype": "string", "shape": [1], "names": None},
        "tick": {"dtype": "int64", "shape": [1], "names": None},
    }
    if table.reward is not None:
        found["next.reward"] = {"dtype": "float32", "shape": [1], "names": None}
        found["next.done"] = {"dtype": "bool", "shape": [1], "names": None}
    if video_size is not None:
        width, height = video_size
        found[CAMERA_KEY] = {"dtype": "video", "shape": [height, width, 3], "names": ["height", "width", "channels"],
                             "info": {"video.height": height, "video.width": width, "video.codec": "h264",
                                      "video.pix_fmt": "yuv420p", "video.is_depth_map": False, "video.fps": fps,
                                      "video.channels": 3, "has_audio": False}}
    for name in ("timestamp", "frame_index", "episode_index", "index", "task_index"):
        found[name] = {"dtype": "float32" if name == "timestamp" else "int64", "shape": [1], "names": None}
    return found


def export_lerobot(run: str | Path, table: TickTable, out: Path, episode_by: str = "auto", video: bool = True,
                   fps: int | None = None) -> dict:
    """Writes the dataset into `out` (which must not exist), whole or not at all: into a hidden folder beside
    it, renamed when every file is written (an export cut short leaves no half dataset); returns what was
    written."""
    pa = needs_export_extra(video and table.camera is not None)
    if out.exists():
        raise ExportError(f"{out}: already exists; give a new folder (nothing is overwritten)")
    by = chosen(table, episode_by)
    starts = episode_starts(table, by)
    fps = fps or fps_of(table)
    partial = out.parent / f".{out.name}.writing"
    shutil.rmtree(partial, ignore_errors=True)  # what an export cut short left
    partial.mkdir(parents=True)
    try:
        episodes = _write_dataset(pa, run, table, starts, fps, video and table.camera is not None, partial)
        partial.rename(out)
    except BaseException:
        shutil.rmtree(partial, ignore_errors=True)
        raise
    return {"episodes": episodes, "frames": len(table), "fps": fps, "episode_by": by,
            "video": video and table.camera is not None, "left_out": table.left_out}


def _write_dataset(pa, run, table: TickTable, starts: np.ndarray, fps: int, with_video: bool, out: Path) -> int:
    """Every file of the dataset into `out`; returns its episodes."""
    episode = episode_index(starts)
    bounds = np.append(np.flatnonzero(starts), len(table))
    found = features(table, even_size(*table.camera.size) if with_video else None, fps)
    task = task_of(table)
    columns = _data_columns(pa, table, episode, np.arange(len(table)) - bounds[episode], fps)
    _write(pa, pa.table(columns), out / DATA_PATH.format(chunk_index=0, file_index=0))
    stats = _stats(columns, found)
    if with_video:
        histogram = encode_video(run, table.camera, table.frames, fps,
                                 out / VIDEO_PATH.format(video_key=CAMERA_KEY, chunk_index=0, file_index=0))
        stats[CAMERA_KEY] = {**image_stats(histogram, QUANTILES), "count": [len(table)]}
    _write(pa, _episodes(pa, bounds, task, fps, with_video), out / EPISODES_PATH.format(chunk_index=0, file_index=0))
    _write(pa, _tasks(pa, [task]), out / "meta/tasks.parquet")
    info = {"codebase_version": CODEBASE_VERSION, "robot_type": _robot_type(table), "total_episodes": len(bounds) - 1,
            "total_frames": len(table), "total_tasks": 1, "chunks_size": 1000, "data_files_size_in_mb": 100,
            "video_files_size_in_mb": 200, "fps": fps, "splits": {"train": f"0:{len(bounds) - 1}"},
            "data_path": DATA_PATH, "video_path": VIDEO_PATH if with_video else None, "features": found}
    (out / "meta/info.json").write_text(json.dumps(info, indent=2))
    (out / "meta/stats.json").write_text(json.dumps(stats, indent=2))
    return len(bounds) - 1


def _robot_type(table: TickTable) -> str | None:
    extra = table.spaces.extra
    if extra.get("platform") == "gym":
        return f"gym:{extra.get('env')}"
    return table.robot or extra.get("platform")


def _data_columns(pa, table: TickTable, episode: np.ndarray, frame_index: np.ndarray, fps: int) -> dict:
    def vectors(values: np.ndarray):  # a feature of shape (1,) is a plain column: LeRobot reads it so
        flat = pa.array(values.astype(np.float32).ravel())
        return flat if values.shape[1] == 1 else pa.FixedSizeListArray.from_arrays(flat, values.shape[1])
    columns = {"observation.state": vectors(table.x), "action": vectors(table.y),
               "confidence": pa.array(table.confidence.astype(np.float32)),
               "mode": pa.array(table.modes.tolist(), pa.string()),
               "source": pa.array(table.sources.tolist(), pa.string()),
               "tick": pa.array(table.ticks)}
    if table.reward is not None:
        columns["next.reward"] = pa.array(np.nan_to_num(table.reward).astype(np.float32))
        columns["next.done"] = pa.array(table.done)
    columns.update({"timestamp": pa.array((frame_index / fps).astype(np.float32)),
                    "frame_index": pa.array(frame_index.astype(np.int64)), "episode_index": pa.array(episode),
                    "index": pa.array(np.arange(len(table), dtype=np.int64)),
                    "task_index": pa.array(np.zeros(len(table), dtype=np.int64))})
    return columns


def _episodes(pa, bounds: np.ndarray, task: str, fps: int, with_video: bool):
    n = len(bounds) - 1
    start, end = bounds[:-1], bounds[1:]
    zeros = np.zeros(n, np.int64)  # one chunk, one file: every episode's data, video and metadata
    columns = {"episode_index": np.arange(n), "tasks": pa.array([[task]] * n, pa.list_(pa.string())),
               "length": end - start, "data/chunk_index": zeros, "data/file_index": zeros,
               "dataset_from_index": start, "dataset_to_index": end}
    if with_video:  # the episodes follow each other in one video: each from its first frame's time
        columns.update({f"videos/{CAMERA_KEY}/chunk_index": zeros, f"videos/{CAMERA_KEY}/file_index": zeros,
                        f"videos/{CAMERA_KEY}/from_timestamp": start / fps,
                        f"videos/{CAMERA_KEY}/to_timestamp": end / fps})
    columns.update({"meta/episodes/chunk_index": zeros, "meta/episodes/file_index": zeros})
    return pa.table({k: v if isinstance(v, pa.Array) else pa.array(np.asarray(v)) for k, v in columns.items()})


def _tasks(pa, tasks: list[str]):
    """The tasks as pandas writes a frame indexed by the task (LeRobot reads it with pandas): the index is a
    column named __index_level_0__ that pandas' metadata names as the index."""
    table = pa.table({"task_index": pa.array(np.arange(len(tasks), dtype=np.int64)),
                      "__index_level_0__": pa.array(tasks, pa.string())})
    pandas = {"index_columns": ["__index_level_0__"], "column_indexes": [], "pandas_version": "2.2.0",
              "creator": {"library": "pyarrow", "version": pa.__version__},
              "columns": [{"name": "task_index", "field_name": "task_index", "pandas_type": "int64",
                           "numpy_type": "int64", "metadata": None},
                          {"name": None, "field_name": "__index_level_0__", "pandas_type": "unicode",
                           "numpy_type": "object", "metadata": None}]}
    return table.replace_schema_metadata({b"pandas": json.dumps(pandas).encode()})


def _stats(columns: dict, found: dict) -> dict:
    stats = {}
    for name, column in columns.items():
        if found[name]["dtype"] not in ("float32", "int64"):
            continue
        values = np.asarray(column.flatten() if hasattr(column, "flatten") else column, dtype=np.float64)
        values = values.reshape(len(column), -1)
        stats[name] = {"min": values.min(0).tolist(), "max": values.max(0).tolist(), "mean": values.mean(0).tolist(),
                       "std": values.std(0).tolist(), "count": [len(values)],
                       **{key: np.quantile(values, q, axis=0).tolist() for key, q in QUANTILES.items()}}
    return stats


def _write(pa, table, path: Path) -> None:
    import pyarrow.parquet as pq
    path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(table, path, compression="snappy")
