"""A recorded camera as one MP4 for the whole dataset: frame i of the dataset at i / fps, H.264 in yuv420p
with a keyframe every 2 frames (LeRobot's setting, for quick random access). Offline, from the recording:
never inside a live service, whose loop an encoder would starve."""
from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import cv2
import numpy as np

from services.export.ticks import Camera
from services.recording.reader import iter_samples

CODEC, PIX_FMT = "libx264", "yuv420p"
OPTIONS = {"g": "2", "crf": "23", "preset": "veryfast"}


def even_size(width: int, height: int) -> tuple[int, int]:
    """yuv420p halves both axes: an odd last row or column is cut."""
    return width - width % 2, height - height % 2


def encode_video(run: str | Path, camera: Camera, frames: np.ndarray, fps: int, out: Path) -> np.ndarray:
    """Writes the camera frame `frames[i]` (an index into `camera`'s frames, non-decreasing; -1 shows the
    first) as the video's frame i; returns the video's histogram per RGB channel (3, 256) over every pixel."""
    import av
    width, height = even_size(*camera.size)
    out.parent.mkdir(parents=True, exist_ok=True)
    wanted = np.maximum(frames, 0)
    with av.open(str(out), "w") as container:
        stream = container.add_stream(CODEC, rate=fps, options=OPTIONS)
        stream.width, stream.height, stream.pix_fmt = width, height, PIX_FMT
        stream.codec_context.time_base = Fraction(1, fps)
        shown = _shown(run, Camera(camera.key))
        ordinal, image, counts = -1, None, None
        histogram = np.zeros((3, 256), np.int64)
        for i, want in enumerate(wanted):
            while ordinal < want:
                ordinal, jpeg = next(shown)
                if ordinal == want:
                    decoded = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
                    if decoded is not None or image is None:  # a JPEG that does not decode: the last one again
                        image = np.zeros((height, width, 3), np.uint8) if decoded is None else \
                            decoded[:height, :width]
                        counts = np.stack([np.bincount(image[..., c].ravel(), minlength=256) for c in (2, 1, 0)])
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="bgr24")
            frame.pts = i
            container.mux(stream.encode(frame))
            histogram += counts
        container.mux(stream.encode())
    return histogram


def image_stats(histogram: np.ndarray, quantiles: dict) -> dict:
    """LeRobot's statistics of a camera from its per-channel histograms: values in [0, 1], each of shape
    (3, 1, 1) as LeRobot keeps them; count is the frames'."""
    levels = np.arange(256) / 255.0
    total = histogram.sum(1)
    mean = histogram @ levels / total
    std = np.sqrt(np.maximum(histogram @ levels**2 / total - mean**2, 0.0))
    cumulative = np.cumsum(histogram, 1) / total[:, None]
    found = {"min": [levels[np.flatnonzero(h)[0]] for h in histogram],
             "max": [levels[np.flatnonzero(h)[-1]] for h in histogram], "mean": mean, "std": std}
    found.update({name: [levels[np.searchsorted(c, q)] for c in cumulative] for name, q in quantiles.items()})
    return {name: np.asarray(values, dtype=np.float64).reshape(3, 1, 1).tolist() for name, values in found.items()}


def _shown(run, camera: Camera):
    """(index, JPEG) of each frame that counts, in the order the first read counted them."""
    for sample in iter_samples(run, {camera.key}):
        frame = camera.take(sample)
        if frame is not None:
            yield len(camera.log_ns) - 1, frame.jpeg
