"""Which samples a full memory forgets: where it is densest, the older of two close samples, so that
every region taught keeps its examples however unevenly the teaching visited them.

A robot's teaching is very uneven: a pendulum held upright gives thousands of nearly identical samples
for every few of its swing. The closest pair is found again after each sample dropped: judged once for
all, every sample of such a cluster names the same nearest neighbour, one drop ends the cluster's turn,
and the rest of the quota is taken from the sparse regions, the rarely visited parts of the task,
until only the cluster is left (Pendulum-v1 taught 4000 ticks: 0 of 777 remembered samples swinging
fast, 87 of the 4000 taught; the student spun the pendulum at full torque).
"""
from __future__ import annotations

import numba as nb
import numpy as np


def densest_older(z: np.ndarray, born: np.ndarray, count: int) -> np.ndarray:
    """A mask of `count` rows of z (scaled inputs) to drop: greedily, of the closest pair of rows left,
    the one born first (ties: the later row). O(m^2) memory; each drop rescans only the rows that named
    the dropped one as their nearest. The products by BLAS, the rest compiled (_drop_closest): in numpy, most
    of it its temporaries before the first drop, a full memory of 800 took 4.5 ms (2.05 now) on the learner's
    answer path, where a leaf that never factors (outputs held still) thins its memory."""
    m = len(z)
    sq = (z * z).sum(1)
    dropped = np.zeros(m, dtype=bool)
    _drop_closest(np.ascontiguousarray(z @ z.T), sq, np.ascontiguousarray(born, dtype=np.int64), min(count, m - 1),
                  dropped)
    return dropped


@nb.njit(cache=True, nogil=True)
def _nearest(d2, a):
    """The first column of row a's least entry (numpy's argmin), and the entry."""
    best, value = 0, d2[a, 0]
    for b in range(1, d2.shape[1]):
        if d2[a, b] < value:
            best, value = b, d2[a, b]
    return best, value


@nb.njit(cache=True, nogil=True)
def _drop_closest(gram, sq, born, count, dropped):
    """densest_older's greedy drops, marked in `dropped`; `gram` (z z') becomes the squared distances, as numpy's
    max(sq + sq' - 2 z z', 0) gives each (the same operations in the same order: no fast-math), inf on the
    diagonal and at every row and column dropped."""
    m = gram.shape[0]
    d2 = gram
    for a in range(m):
        for b in range(m):
            d2[a, b] = max((sq[a] + sq[b]) - 2.0 * gram[a, b], 0.0)
        d2[a, a] = np.inf
    nearest, gap = np.empty(m, dtype=np.int64), np.empty(m)
    for a in range(m):
        nearest[a], gap[a] = _nearest(d2, a)
    for _ in range(count):
        i, least = 0, gap[0]
        for a in range(1, m):
            if gap[a] < least:
                i, least = a, gap[a]
        j = nearest[i]
        gone = i if born[i] < born[j] or (born[i] == born[j] and i > j) else j
        dropped[gone] = True
        for a in range(m):
            d2[gone, a] = np.inf
            d2[a, gone] = np.inf
        gap[gone] = np.inf
        for a in range(m):
            if not dropped[a] and nearest[a] == gone:
                nearest[a], gap[a] = _nearest(d2, a)


_drop_closest(np.zeros((2, 2)), np.zeros(2), np.zeros(2, dtype=np.int64), 1, np.zeros(2, dtype=bool))  # built once, at
# import (from numba's cache after the first), not at a learner's first full memory
