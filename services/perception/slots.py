"""A colour-blind input layout for ball seeking: the blobs in view in slots, largest first, each as
(seen, x, y, area, orange), instead of the detector's fixed place per colour.

Why: with the detector's layout a pink ball and an orange ball are seen on different inputs. A
student taught with pink only has never seen the orange inputs change, so no regressor can
link them to turning or walking: shown orange alone, it answers as for an empty view and keeps
searching. The paper's emergent behaviour (the untaught student approaches orange like pink)
needs the two balls to share inputs and differ in one, the colour, that never varied in
teaching: then the student generalises over it, and a short correction teaches it to matter.
This is pre-processing between perception and DL, which the paper allows (section V.B).
"""
from __future__ import annotations

import numpy as np

from bus_schema.spaces import Box
from services.perception.blobs import BlobDetector

SLOT_FIELDS = ("seen", "x", "y", "area", "orange")


class BlobSlots:
    """encode(detector vector) -> slot vector and decode back, for the detector's pink and orange."""

    def __init__(self, detector: BlobDetector | None = None):
        self.detector = detector or BlobDetector()
        self.colours = list(self.detector.colours)
        if self.colours != ["pink", "orange"]:
            raise ValueError(f"BlobSlots encodes the pink and orange balls, got colours {self.colours}")

    def names(self) -> tuple[str, ...]:
        return tuple(f"blob{k + 1}_{field}" for k in range(len(self.colours)) for field in SLOT_FIELDS)

    def box(self) -> Box:
        n = len(self.colours)
        return Box((0.0, -1.0, -1.0, 0.0, 0.0) * n, (1.0, 1.0, 1.0, 1.0, 1.0) * n, self.names(), ("1",) * (5 * n))

    def encode(self, blobs: np.ndarray) -> np.ndarray:
        per_colour = np.asarray(blobs, dtype=np.float64).reshape(len(self.colours), 4)
        seen = [i for i in range(len(self.colours)) if per_colour[i, 0] > 0.5]
        order = sorted(seen, key=lambda i: -per_colour[i, 3])  # largest (nearest) first
        slots = np.zeros((len(self.colours), len(SLOT_FIELDS)))
        for k, i in enumerate(order):
            slots[k, :4], slots[k, 4] = per_colour[i], float(self.colours[i] == "orange")
        return slots.ravel()

    def decode(self, slots: np.ndarray) -> np.ndarray:
        per_colour = np.zeros((len(self.colours), 4))
        for slot in np.asarray(slots, dtype=np.float64).reshape(len(self.colours), len(SLOT_FIELDS)):
            if slot[0] > 0.5:
                per_colour[1 if slot[4] > 0.5 else 0] = slot[:4]
        return per_colour.ravel()
