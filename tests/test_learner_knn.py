"""kNN's width learned from the stream: on random maps taught along smooth trajectories, where a
width fixed by the input's dimension left it sure of answers wrong by a tenth of the span, it asks."""
import math

import numpy as np
import pytest

from services.experiments.unknown import SURE, UNSURE, WRONG, judge, pooled
from services.learners import make_learner
from services.learners.distance_calibration import KEEP, MIN_JUDGED, DistanceCalibration
from services.learners.unknown_tasks import draw_task

SMALL = (-np.ones(4), np.ones(4), -np.ones(2), np.ones(2))
TASKS = (30, 31, 32)  # none of the tasks the width's rule was chosen on (0-29)


def calibration_on(tasks, params) -> dict:
    return pooled([c for t in tasks for c in judge(draw_task(t, *SMALL), "knn", params, seed=t)])


@pytest.mark.slow  # 4.8-5.0 s of CPU on a 2-core machine of 2026-12 (the fast tier failed it in a fresh clone)
def test_on_random_maps_along_trajectories_knn_asks_where_it_is_wrong():
    fixed = calibration_on(TASKS, {"length_scale": 0.5 * math.sqrt(4)})  # the width before it was learned
    learned = calibration_on(TASKS, {})
    print(f"\nfixed width: sure RMS {fixed['confident_rms']:.3f}, asks on {fixed['asks_when_wrong']:.0%} of "
          f"{fixed['wrong_ticks']} ticks wrong by > {WRONG}; learned: {learned['confident_rms']:.3f}, "
          f"{learned['asks_when_wrong']:.0%}")
    assert fixed["asks_when_wrong"] < 0.3 and fixed["confident_rms"] > 0.1  # the failure this mends
    assert learned["asks_when_wrong"] >= 0.7, f"asks (< {UNSURE}) on {learned['asks_when_wrong']:.0%}"
    assert learned["confident_rms"] is None or learned["confident_rms"] < 0.1, f"sure (> {SURE}) but wrong"


def test_where_the_stream_shows_a_map_densely_the_width_keeps_knn_sure():
    rng = np.random.default_rng(0)
    t = np.arange(6000) / 60.0
    xs = np.column_stack([np.sin(2 * np.pi * t / 0.36), np.cos(2 * np.pi * t / 0.36), rng.uniform(-1, 1, 6000).cumsum()
                          % 2 - 1])  # a gait clock and a slowly wandering command, as the walk level's inputs
    ys = np.column_stack([np.sin(2 * np.pi * t / 0.36) * 0.5 + 0.2 * xs[:, 2]])
    model = make_learner("knn", 3, 1)
    model.learn_many(xs[:5000], ys[:5000])
    p = model.predict_many(xs[5000:])
    assert np.abs(p.y - ys[5000:]).max() < 0.1
    assert np.median(p.confidence) > 0.75 and np.mean(p.confidence < UNSURE) < 0.05


def test_the_width_needs_judged_pairs_and_a_snapshot_cannot_poison_it():
    calibration = DistanceCalibration()
    for _ in range(MIN_JUDGED - 1):
        calibration.judge(0.1, 0.5)
    assert calibration.width(1.0) == 1.0  # too few: the given width
    calibration.judge(0.1, 0.5)
    slope = 0.2  # share of the span per unit of distance: confidence 0.25 where the error reaches 0.1
    assert calibration.width(1.0) == pytest.approx(0.1 / (math.sqrt(2 * math.log(4)) * slope))
    calibration.judge(float("nan"), 1.0)
    calibration.judge(0.1, 0.0)  # a repeated input says nothing of distance
    assert calibration.count == MIN_JUDGED
    hostile = DistanceCalibration()
    hostile.__setstate__({"slopes": np.array([np.nan, -5.0, np.inf] * 10), "count": 10**12})
    assert hostile.count == 30 and np.all(np.isfinite(hostile.slopes)) and np.all(hostile.slopes >= 0)
    assert hostile.width(1.0) == 1.0  # nothing learned from it: the given width
    full = DistanceCalibration()
    full.__setstate__({"slopes": np.full(KEEP + 5, 0.2), "count": KEEP + 5})
    assert full.count == KEEP + 5 and full.width(1.0) == pytest.approx(calibration.width(1.0))
