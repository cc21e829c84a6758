"""JPEG for camera frames on the bus. Frames are RGB uint8 (height, width, 3) on both sides;
OpenCV's codec speaks BGR, so the swap happens here and nowhere else."""
from __future__ import annotations

import cv2
import numpy as np

DEFAULT_QUALITY = 80  # ~3-5 kB per 208x160 frame; colours stay well inside the blob thresholds


def encode_rgb(frame: np.ndarray, quality: int = DEFAULT_QUALITY) -> bytes:
    frame = np.asarray(frame)
    if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
        raise ValueError(f"expected an RGB uint8 frame of shape (height, width, 3), got {frame.dtype} {frame.shape}")
    ok, data = cv2.imencode(".jpg", cv2.cvtColor(frame, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise RuntimeError("OpenCV could not encode the frame as JPEG")
    return data.tobytes()


def decode_rgb(data: bytes) -> np.ndarray:
    bgr = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_COLOR)
    if bgr is None:
        raise ValueError(f"not a JPEG image ({len(data)} bytes); expected what encode_rgb produces")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
