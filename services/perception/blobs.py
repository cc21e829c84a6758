"""Colour blobs: for each named colour, is it in view, where, and how big.

The output vector has four entries per colour, colours in the order given (defaults: pink,
then orange):
    seen  1 if a blob of at least `min_pixels` pixels was found, else 0
    x     blob centroid, -1 left edge ... +1 right edge (0 when not seen)
    y     blob centroid, -1 top edge ... +1 bottom edge (0 when not seen)
    area  blob pixels / frame pixels, in [0, 1]
Only the largest blob of each colour counts (one ball per colour in the arena). Thresholds are
HSV in OpenCV's scale (H 0-179, S and V 0-255); a colour may list several ranges, e.g. to
wrap a red hue around 0.
"""
from __future__ import annotations

import cv2
import numpy as np

from bus_schema.spaces import Box

HsvRange = tuple[tuple[int, int, int], tuple[int, int, int]]

# tuned on the arena's balls under the tiny renderer's lighting, after JPEG at quality 80:
# pink renders at H 164-165, orange at H 15; clutter is blue/teal/green/grey (H 60-120 or S < 40)
DEFAULT_COLOURS: dict[str, tuple[HsvRange, ...]] = {
    "pink": (((150, 80, 60), (178, 255, 255)),),
    "orange": (((6, 120, 60), (24, 255, 255)),),
}
FIELDS = ("seen", "x", "y", "area")


class BlobDetector:
    def __init__(self, colours: dict[str, tuple[HsvRange, ...]] | None = None, min_pixels: int = 6):
        self.colours = dict(DEFAULT_COLOURS if colours is None else colours)
        if not self.colours:
            raise ValueError("BlobDetector needs at least one colour")
        self.min_pixels = min_pixels

    def describe(self) -> list[str]:
        """Names of the output entries, e.g. ['pink_seen', 'pink_x', ...]."""
        return [f"{name}_{field}" for name in self.colours for field in FIELDS]

    def box(self) -> Box:
        """The output as a space: bounds, names and units of every entry."""
        n = len(self.colours)
        return Box((0.0, -1.0, -1.0, 0.0) * n, (1.0, 1.0, 1.0, 1.0) * n, tuple(self.describe()), ("1",) * (4 * n))

    def _mask(self, hsv: np.ndarray, ranges) -> np.ndarray:
        mask = None
        for low, high in ranges:
            part = cv2.inRange(hsv, np.array(low, dtype=np.uint8), np.array(high, dtype=np.uint8))
            mask = part if mask is None else cv2.bitwise_or(mask, part)
        return mask

    def _largest_blob(self, mask: np.ndarray) -> np.ndarray:
        height, width = mask.shape
        count, _, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
        if count <= 1:
            return np.zeros(4)
        best = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))  # label 0 is the background
        pixels = int(stats[best, cv2.CC_STAT_AREA])
        if pixels < self.min_pixels:
            return np.zeros(4)
        cx, cy = centroids[best]  # pixel indices; pixel i spans [i, i+1), so its centre is i + 0.5
        return np.array([1.0, 2 * (cx + 0.5) / width - 1, 2 * (cy + 0.5) / height - 1, pixels / (width * height)])

    def detect(self, frame_rgb: np.ndarray) -> np.ndarray:
        """The blob vector (float64, 4 per colour) of an RGB uint8 frame."""
        hsv = cv2.cvtColor(np.asarray(frame_rgb), cv2.COLOR_RGB2HSV)
        return np.concatenate([self._largest_blob(self._mask(hsv, ranges)) for ranges in self.colours.values()])

    def to_pixels(self, x: float, y: float, width: int, height: int) -> tuple[float, float]:
        """Back from normalised (x, y) to pixel coordinates (x right, y down, centres at .5)."""
        return (x + 1) / 2 * width, (y + 1) / 2 * height
