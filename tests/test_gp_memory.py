"""Which samples a full GP memory forgets (gp_memory.densest_older): compiled, the same drops as the algorithm
written plainly in numpy below (as it was served before), ties and equal ages included, so that a replay thins
as the run it replays did."""
import numpy as np
import pytest

from services.learners.gp_memory import densest_older


def plainly(z: np.ndarray, born: np.ndarray, count: int) -> np.ndarray:
    """Greedily, of the closest pair of rows left, the one born first (ties: the later row)."""
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
        nearest[orphans] = d2[orphans].argmin(1)
        gap[orphans] = d2[orphans, nearest[orphans]]
    return dropped


@pytest.mark.parametrize("seed", range(40))
def test_the_same_rows_are_dropped_as_the_plain_algorithm_drops(seed):
    rng = np.random.default_rng(seed)
    m, n = int(rng.integers(2, 400)), int(rng.integers(1, 20))
    z = [rng.normal(size=(m, n)),  # scattered
         np.cumsum(rng.normal(size=(m, n)) * 0.01, axis=0),  # a robot's stream
         np.round(rng.normal(size=(m, n)), 1)][seed % 3]  # repeated rows: equal distances
    born = rng.integers(0, m // 2 + 1, m) if seed % 2 else np.arange(m)  # equal ages too
    count = int(rng.integers(1, m + 2))
    dropped = densest_older(z, born, count)
    assert dropped.sum() == min(count, m - 1)
    assert np.array_equal(dropped, plainly(z, born, count))


def test_of_two_close_samples_the_older_goes():
    z = np.array([[0.0], [0.01], [5.0], [10.0]])
    assert densest_older(z, np.array([3, 1, 0, 2]), 1).tolist() == [False, True, False, False]
