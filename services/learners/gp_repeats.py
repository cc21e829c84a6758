"""A pair taught again, in a leaf of the GP (gp_local.LocalGP): counted, not remembered again.

A pair within DUPLICATE of a remembered one (of each input's spread and each output's taught span, exactly
along what never varied) is a repeat. Remembered each time, epochs over one data set would tell the evidence
there is no noise, and a robot held still gives thousands (a pendulum held upright), which drove the
incremental factor's rounding up to answers of 1e155. Skipped, each different answer at a place weighed one:
a ball seeker taught by keys saw nothing in 105 lessons, 97 turned, 8 had a key let go a tick late, and the
student answered the mean of the 5 different answers and walked straight ahead for good. So the remembered
sample weighs as many samples as it was taught (its noise divided by that), up to REPEATS_COUNTED, and each
other answer at its place takes one away (down to 1 / REPEATS_COUNTED): a place answers as the teacher mostly
did of late, and a correction outweighs the oldest habit there after REPEATS_COUNTED lessons. Judged in the
data's units, not the fit's: a sample the fit of the moment finds redundant (an early fit sure of a wrong
map) may be just what shows it wrong (mirroring's seed 6 stopped learning at 0.17 rad).
"""
from __future__ import annotations

import numpy as np

from . import gp_kernels
from .inputs import kernel_ready

DUPLICATE = 1e-3  # of an input's spread, of an output's taught span: a pair this near a remembered one is a repeat
REPEATS_COUNTED = 16


class Repeats:
    """LocalGP's repeats: `_repeats[j]` per remembered row, the factor kept as K + ratio / repeats."""

    def _taught_again(self, x: np.ndarray, y: np.ndarray) -> bool:
        """Counts (x, y) against the remembered pairs at x's place; False when it is to be remembered."""
        others = np.empty(self._m, dtype=np.int64)
        same, count = gp_kernels.same_place(self._xs, self._ys, self._m, kernel_ready(x), kernel_ready(y),
                                            DUPLICATE * self._input_sd(), DUPLICATE * self._taught.span, others)
        if same < 0 and count == 0:
            return False  # a place not taught before: nothing to weigh
        rows = others[:count]
        repeats = np.maximum(self._repeats[rows] - 1.0, 1.0 / REPEATS_COUNTED)
        if same >= 0:
            self._born[same] = self._y_count  # as new as this lesson
            rows = np.append(rows, same)
            repeats = np.append(repeats, min(self._repeats[same] + 1.0, REPEATS_COUNTED))
        self._weigh(rows, repeats)
        return same >= 0

    def _weigh(self, rows: np.ndarray, repeats: np.ndarray) -> None:
        """Remembered `rows` weigh `repeats` samples each from now on; the factor is changed in place, a
        rank-one update per row changed (O(m^2) each), and beta solved again from the first."""
        before = self._repeats[rows]
        changed = before != repeats
        if not changed.any():
            return  # (a sample taught again past REPEATS_COUNTED costs nothing)
        rows, before, repeats = rows[changed], before[changed], repeats[changed]
        self._repeats[rows] = repeats
        if not self._factored:
            return  # weighed when the factor is built
        if self._deferring:
            self._stale = True
            return
        m = self._m
        for j, old, new in zip(rows, before, repeats):
            if not gp_kernels.reweigh(self._chol, m, int(j), self._row_ratio(int(j)) * (1.0 / new - 1.0 / old)):
                self._rebuild()  # rounding: from scratch
                break
        else:
            gp_kernels.resolve(self._chol, self._beta, self._ys[:m] - self._hyper.mu, m, int(rows.min()))
            self._factor_changed(int(rows.min()))
