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

import numpy as np


def densest_older(z: np.ndarray, born: np.ndarray, count: int) -> np.ndarray:
    """A mask of `count` rows of z (scaled inputs) to drop: greedily, of the closest pair of rows left,
    the one born first (ties: the later row). O(m^2) memory; each drop rescans only the rows that named
    the dropped one as their nearest."""
    m = len(z)
    sq = (z * z).sum(1)
    d2 = np.maximum(sq[:, None] + sq[None, :] - 2.0 * (z @ z.T), 0.0)
    np.fill_diagonal(d2, np.inf)
    nearest = d2.argmin(1)
    gap = d2[np.arange(m), nearest]
    dropped = np.zeros(m, dtype=bool)
    for _ in range(min(count, m - 1)):
        i = int(gap.argmin())
        j = int(nearest[i])
        gone = i if (born[i], -i) < (born[j], -j) else j
        dropped[gone] = True
        d2[gone, :] = np.inf
        d2[:, gone] = np.inf
        gap[gone] = np.inf
        orphans = np.flatnonzero(~dropped & (nearest == gone))
        if len(orphans):
            nearest[orphans] = d2[orphans].argmin(1)
            gap[orphans] = d2[orphans, nearest[orphans]]
    return dropped
