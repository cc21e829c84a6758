"""A place taught again weighs as many lessons (gp_repeats.REPEATS_COUNTED): the student answers as the
teacher mostly did there, not the mean of each different answer once. A keyboard-taught ball seeker saw
nothing in 105 lessons: 97 said turn, 8 (a key let go a tick late) said walk; it walked straight for good."""
import numpy as np

from services.learners import make_learner
from services.learners.gp_evidence import first_hyper, spread_rows
from services.learners.gp_local import LocalGP
from services.learners.gp_repeats import REPEATS_COUNTED
from services.learners.gp_split import fit_and_split


def _taught_around(model, rng, count=60):
    for x in rng.uniform(-1, 1, (count, 2)):
        model.learn_one(x, [np.sin(2 * x[0]), np.cos(x[1])])


def test_a_place_answers_as_the_teacher_mostly_did_there():
    rng = np.random.default_rng(0)
    model = make_learner("gp", 2, 2, seed=0, near=0.2)
    _taught_around(model, rng)
    here, usual, slip = np.array([0.3, -0.2]), np.array([0.0, 0.8]), np.array([0.15, 0.0])
    for lesson in range(40):  # one slip in five, each slip a little different (as a late key's are)
        model.learn_one(here, slip + [0.0, 0.01 * lesson] if lesson % 5 == 4 else usual)
    answer = model.predict_one(here).y
    # the mean of the 9 different answers once each: (0.13, 0.20); as mostly taught: (0.0, 0.8)
    assert np.abs(answer - usual).max() < 0.25 * np.abs(slip - usual).max(), answer.round(3)


def test_a_correction_outweighs_an_old_habit_after_as_many_lessons_as_are_counted():
    """A place taught one answer 200 times, then another as many times as a sample's repeats are counted: the
    newer wins (on main the two answers weighed one each, and the student answered their mean, 0.0, for ever)."""
    model = make_learner("gp", 2, 1, seed=0, near=0.2)
    places = {(-1.0, -1.0): 0.2, (1.0, 1.0): -0.3, (1.0, -1.0): 0.7, (-1.0, 1.0): -0.8}
    here = np.zeros(2)
    for t in range(200):
        place = list(places)[t % 4]
        model.learn_one(np.array(place), [places[place]])
        model.learn_one(here, [0.5])  # the habit
    assert abs(model.predict_one(here).y[0] - 0.5) < 0.01
    for _ in range(REPEATS_COUNTED):
        model.learn_one(here, [-0.5])  # the correction: each lesson takes one from the habit's weight
    assert model.predict_one(here).y[0] < -0.45


def test_the_factor_updated_in_place_is_the_rebuilt_one():
    rng = np.random.default_rng(2)
    leaf = LocalGP(2, 2, seed=0)
    _taught_around(leaf, rng, 40)
    repeated = leaf._xs[7].copy(), leaf._ys[7].copy()
    for _ in range(5):
        leaf.learn_one(*repeated)
    leaf.learn_one(repeated[0], repeated[1] + 0.5)  # another answer there
    assert leaf._repeats[7] == 5.0 and leaf._repeats[40] == 1.0 and leaf.size == 41
    m = leaf._m
    gram = leaf._kernel(leaf._xs[:m], leaf._xs[:m]) + np.diag(leaf._ratio / leaf._repeats[:m])
    chol = np.linalg.cholesky(gram)
    assert np.allclose(leaf._chol[:m, :m], chol, atol=1e-8)
    beta = np.linalg.solve(chol, leaf._ys[:m] - leaf._hyper.mu)
    assert np.allclose(leaf._beta[:m], beta, atol=1e-6)


def test_repeats_survive_a_snapshot_and_a_snapshot_from_before_loads():
    rng = np.random.default_rng(3)
    leaf = LocalGP(2, 2, seed=0)
    _taught_around(leaf, rng, 30)
    for _ in range(3):
        leaf.learn_one(leaf._xs[4].copy(), leaf._ys[4].copy())
    state = leaf.__getstate__()
    copy = LocalGP.__new__(LocalGP)
    copy.__setstate__(dict(state))
    assert copy._repeats[4] == 4.0
    old = {k: v for k, v in state.items() if k != "_repeats"}  # written before repeats were counted
    before = LocalGP.__new__(LocalGP)
    before.__setstate__(old)
    assert np.array_equal(before._repeats, np.ones(len(before._xs)))
    before.learn_one([0.1, 0.1], [0.2, 0.3])
    assert np.isfinite(before.predict_one([0.1, 0.1]).y).all()


def test_a_fit_sees_the_place_the_teacher_dwelt_on():
    """A ball seeker's 'nothing seen' (every input 0) was taught 20,929 times in a day, remembered once (weighing 16)
    among 758 samples of a ball in view; the fit's 256 rows spread over the memory missed it, ruled 'seen' an input
    that never varied and answered 'nothing seen' as a ball dead ahead: (0.03, 0.66), sure at 0.997, where every
    lesson there said (0.0, 0.8). A fit now also sees the rows taught again, the most repeated first
    (gp_evidence.fitted_rows)."""
    rng = np.random.default_rng(3)
    m, fit_points = 759, 256
    a, b = rng.uniform(-1, 1, (2, m))
    xs = np.column_stack([np.ones(m), a, b])
    ys = np.column_stack([0.15 * (1 - np.abs(a)), -0.5 * a])
    dwelt = next(k for k in range(m // 3, m) if k not in set(spread_rows(m, fit_points)))
    xs[dwelt], ys[dwelt] = 0.0, [0.0, 0.8]
    repeats = np.ones(m)
    repeats[dwelt] = REPEATS_COUNTED
    settings = (fit_points, 2.0, 1e-5, 60, np.array([0.03, 0.16]), False)
    assert not fit_and_split(xs, ys, first_hyper(3, 2), *settings)[0].varied[0]  # as the fit was: 'seen' unseen
    hyper, _ = fit_and_split(xs, ys, first_hyper(3, 2), *settings, repeats=repeats)
    assert hyper.varied[0]
