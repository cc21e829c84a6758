"""The random-map teacher: a seeded smooth map of chosen inputs onto chosen outputs, in range."""
import numpy as np
import pytest

from bus_schema.spaces import Spaces
from services.platforms.aibo.platform import JOINTS_BOX
from services.teachers import make_teacher

SPACES = Spaces(JOINTS_BOX, JOINTS_BOX)
TAIL_TO_HEAD = {"inputs": ["tail_tilt", "tail_pan"], "outputs": [12, 13]}


def sweep(n=400, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(JOINTS_BOX.low, JOINTS_BOX.high, (n, 18))


def test_same_seed_same_map_other_seed_another():
    a, b, c = (make_teacher("random-map", SPACES, seed=s, **TAIL_TO_HEAD) for s in (3, 3, 4))
    xs = sweep()
    ya, yb, yc = (np.array([t(x)[0] for x in xs]) for t in (a, b, c))
    assert np.array_equal(ya, yb) and np.abs(ya - yc).max() > 0.1


def test_speaks_for_its_outputs_only_in_range_and_from_its_inputs_only():
    teacher = make_teacher("random-map", SPACES, seed=1, span=1.3, **TAIL_TO_HEAD)
    xs = sweep()
    ys = np.array([teacher(x)[0] for x in xs])
    assert teacher.mask.tolist() == [1.0 if i in (12, 13) else 0.0 for i in range(18)]
    assert all(JOINTS_BOX.contains(y) for y in ys)
    assert np.ptp(ys[:, 12]) > 0.3 and np.ptp(ys[:, 13]) > 0.3 and np.ptp(ys[:, 13]) <= 1.3 + 1e-9
    moved = xs.copy()
    moved[:, :16] = sweep(seed=9)[:, :16]  # everything but the tail
    assert np.array_equal(np.array([teacher(x)[0] for x in moved]), ys)


@pytest.mark.parametrize("params,field", [({"inputs": [18]}, "inputs"), ({"outputs": ["ear"]}, "outputs"),
                                          ({"inputs": [1, 1]}, "inputs"), ({"span": -1.0}, "span"),
                                          ({"seed": "x"}, "seed")])
def test_bad_parameters_name_the_field(params, field):
    with pytest.raises(ValueError, match=field):
        make_teacher("random-map", SPACES, **params)
