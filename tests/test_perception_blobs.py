"""BlobDetector on synthetic frames, and the JPEG pair."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from services.perception.blobs import BlobDetector
from services.perception.jpeg import decode_rgb, encode_rgb

PINK, ORANGE, GREY = (255, 105, 180), (255, 128, 0), (180, 178, 166)


def frame_with(*discs) -> np.ndarray:
    frame = np.zeros((160, 208, 3), dtype=np.uint8)
    frame[:] = GREY
    for colour, centre, radius in discs:
        cv2.circle(frame, centre, radius, colour, thickness=-1)
    return frame


def test_vector_layout_is_documented_and_bounded():
    detector = BlobDetector()
    assert detector.describe() == ["pink_seen", "pink_x", "pink_y", "pink_area",
                                   "orange_seen", "orange_x", "orange_y", "orange_area"]
    box = detector.box()
    assert box.dims == 8 and box.names == tuple(detector.describe())


def test_blobs_found_where_drawn():
    frame = frame_with((PINK, (52, 40), 12), (ORANGE, (156, 120), 8))
    vector = BlobDetector().detect(frame)
    pink, orange = vector[:4], vector[4:]
    assert pink[0] == 1 and orange[0] == 1
    # pixel (52, 40) has its centre at (52.5, 40.5): x = 2 * 52.5 / 208 - 1
    assert pink[1:3] == pytest.approx([2 * 52.5 / 208 - 1, 2 * 40.5 / 160 - 1], abs=0.01)
    assert orange[1:3] == pytest.approx([2 * 156.5 / 208 - 1, 2 * 120.5 / 160 - 1], abs=0.01)
    assert pink[3] == pytest.approx(np.pi * 12 ** 2 / (208 * 160), rel=0.1)
    assert orange[3] < pink[3]


def test_nothing_seen_gives_zeros_and_specks_are_ignored():
    assert np.array_equal(BlobDetector().detect(frame_with()), np.zeros(8))
    speck = frame_with((PINK, (100, 100), 1))
    assert BlobDetector(min_pixels=6).detect(speck)[0] == 0


def test_colours_are_configurable_and_hue_can_wrap():
    red = {"red": (((0, 120, 60), (8, 255, 255)), ((172, 120, 60), (179, 255, 255)))}
    frame = frame_with(((255, 0, 0), (30, 30), 10), ((255, 0, 40), (150, 100), 14))
    vector = BlobDetector(colours=red).detect(frame)
    assert vector.shape == (4,) and vector[0] == 1
    assert vector[1] > 0  # the larger disc (hue just below 180) wins


def test_jpeg_round_trip_keeps_the_frame_and_the_blobs():
    frame = frame_with((PINK, (60, 80), 15), (ORANGE, (150, 50), 10))
    data = encode_rgb(frame)
    decoded = decode_rgb(data)
    assert isinstance(data, bytes) and decoded.shape == frame.shape and decoded.dtype == np.uint8
    assert np.abs(decoded.astype(int) - frame).mean() < 3
    assert BlobDetector().detect(decoded) == pytest.approx(BlobDetector().detect(frame), abs=0.02)
    with pytest.raises(ValueError, match="not a JPEG"):
        decode_rgb(b"nope")
    with pytest.raises(ValueError, match="RGB uint8"):
        encode_rgb(frame.astype(np.float32))
