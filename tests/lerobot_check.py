"""Loads a dataset with LeRobot's own reader (the standalone `lerobot-dataset` package) and prints what it
read as one JSON object, for tests/test_export_live.py to compare with the recording. Run by a Python that
has lerobot-dataset (and the torch and torchvision it imports): python tests/lerobot_check.py DIR."""
import json
import sys

import numpy as np


def main(root: str) -> None:
    from ledataset.datasets.lerobot_dataset import LeRobotDataset
    ds = LeRobotDataset("dogged/export", root=root)
    frames = ds.hf_dataset.with_format(None)  # plain values, not tensors: this script has no use for torch
    found = {"episodes": ds.num_episodes, "frames": ds.num_frames, "fps": ds.fps,
             "features": {k: {"dtype": v["dtype"], "shape": list(v["shape"]), "names": v["names"]}
                          for k, v in ds.features.items()},
             "columns": {k: list(frames[k]) for k in frames.column_names},
             "episode_lengths": [int(ep["length"]) for ep in ds.meta.episodes]}
    if ds.meta.video_keys:  # each episode's first and last frame, through LeRobotDataset's own decoder
        key = ds.meta.video_keys[0]
        shown = {}
        for ep in ds.meta.episodes:
            for index in (ep["dataset_from_index"], ep["dataset_to_index"] - 1):
                image = np.asarray(ds[index][key])  # (channels, height, width), floats in [0, 1]
                shown[int(index)] = [list(image.shape), float(image.mean())]
        found["video"] = {"key": key, "shown": shown, "backend": ds.video_backend}
    print(json.dumps(found))


if __name__ == "__main__":
    main(sys.argv[1])
