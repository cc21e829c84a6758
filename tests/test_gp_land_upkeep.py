"""Finished fits landed on demand (Learner.land_upkeep; the learner service no longer calls it): served live, a fit that
ended is held with its factor until its leaf is taught or asked again, so a lesson's fits stay in the learner's memory
as long as teaching pauses (issue 31: 40 MB after a mirroring lesson). And a fit that raised is logged."""
from concurrent.futures import Future

import numpy as np
import pytest

from services.learners import make_learner
from services.learners.gp_fitting import failed
from services.learners.unknown_tasks import draw_task
from services.waiting import poll


def leaves(model) -> list:
    return [leaf for tree in model._learners() for leaf in tree.parts]


def held(leaf) -> int:
    """Finished jobs a leaf holds, unapplied."""
    return sum(job is not None and job.done() for job in (leaf._searching, leaf._pending and leaf._pending[0]))


@pytest.mark.live  # served live: fits in processes of their own
def test_a_lessons_finished_fits_are_landed_and_their_answers_made_ready_between_answers():
    task = draw_task(5, -np.ones(6), np.ones(6), -np.ones(3), np.ones(3), relevant=(2, 3), taught=(1, 2))
    xs = task.stream(30.0, 30.0, "trajectory")
    ys = task.target(xs)
    model = make_learner("per-output", 6, 3, seed=0, base="gp", params={"memory": 120, "fit_points": 64})
    model.serve_live()
    for x, y in zip(xs, ys):  # as a robot's ticks come: an answer, then the pair taught
        model.predict_one(x)
        model.learn_one(x, y)
    assert poll(lambda: model.upkeep_under_way == 0, 120.0), "the lesson's fits end"
    before = sum(held(leaf) for leaf in leaves(model))
    assert before > 0, "the last fits are held until their leaves are called again"
    landed = 0
    while step := model.land_upkeep(0.002):
        landed += step
        poll(lambda: model.upkeep_under_way == 0, 60.0)  # a landed fit that saw less than was taught fits again
    assert landed >= before
    assert [held(leaf) for leaf in leaves(model)] == [0] * len(leaves(model))
    for leaf in leaves(model):
        assert not leaf._factored or (leaf._rows32 == leaf._m and leaf._alpha_ok), "the answer's copies made ready"
    assert model.land_upkeep(0.002) == 0


def test_a_fit_that_raised_is_logged_and_leaves_the_leaf_as_it_was(caplog):
    ok, broken = Future(), Future()
    ok.set_result((None, None))
    broken.set_exception(MemoryError("out of memory"))
    assert not failed(ok, "fit")
    assert failed(broken, "fit") and "MemoryError: out of memory" in caplog.text
