"""Figure 5 evaluation and the episode judges, on synthetic recordings."""
import numpy as np
import pytest

from services.experiments import evaluate, judges


class HalfTeacher:
    """Says y = x / 2 for x >= 0 and nothing otherwise."""

    class spaces:
        class output:
            dims = 1

    def __call__(self, x):
        return (np.array([x[0] / 2]), 1.0) if x[0] >= 0 else (None, 1.0)


def test_teacher_outputs_run_on_every_input_with_nan_for_silence():
    y = evaluate.teacher_outputs(HalfTeacher(), np.array([[2.0], [-1.0], [4.0]]))
    np.testing.assert_array_equal(y[[0, 2], 0], [1.0, 2.0])
    assert np.isnan(y[1, 0])


def test_error_over_time_is_rms_over_chosen_outputs_with_scale():
    teacher = np.array([[1.0, 0.0, 5.0], [0.0, 0.0, 0.0]])
    student = np.array([[0.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    np.testing.assert_allclose(evaluate.error_over_time(teacher, student, outputs=[0, 1]), [np.sqrt(0.5), np.sqrt(2)])
    np.testing.assert_allclose(evaluate.error_over_time(teacher, student, scale=[1, 2, 5]), [np.sqrt(2 / 3), np.sqrt(1 / 3)])


def test_teaching_bands_and_the_drop_within_the_first():
    t = np.arange(100) / 10.0
    teaching = (t >= 2) & (t < 5) | (t >= 8)
    assert evaluate.teaching_bands(t, teaching) == [pytest.approx((2.0, 5.0)), pytest.approx((8.0, 10.0))]
    error = np.where(t < 2, 0.5, np.exp(-(t - 2)))  # high when teaching starts, then falls
    start, end = evaluate.first_band_drop(t, error, teaching)
    assert start > 0.6 and end < 0.2
    with pytest.raises(ValueError, match="never active"):
        evaluate.first_band_drop(t, error, np.zeros(100, dtype=bool))


def test_asking_rate_counts_the_students_ticks_only():
    modes = np.array(["teacher", "unsure", "student", "unsure", "teacher"])
    assert evaluate.asking_rate(modes) == pytest.approx(2 / 3)
    assert evaluate.asking_rate(modes, [False, False, True, True, True]) == pytest.approx(1 / 2)
    assert evaluate.asking_rate(modes, [True, False, False, False, True]) is None  # it never drove


def test_plot_marks_where_the_robot_asks(tmp_path):
    t = np.arange(50) / 10.0
    plain = evaluate.plot_error(tmp_path / "plain.png", t, np.abs(np.sin(t)), t < 2, "synthetic")
    asking = evaluate.plot_error(tmp_path / "asking.png", t, np.abs(np.sin(t)), t < 2, "synthetic", asking=t > 3)
    assert asking.read_bytes() != plain.read_bytes()


def test_moving_average_is_trailing():
    np.testing.assert_allclose(evaluate.moving_average(np.array([2.0, 4.0, 6.0, 8.0]), 2), [2.0, 3.0, 5.0, 7.0])


def test_plot_writes_a_png(tmp_path):
    t = np.arange(50) / 10.0
    path = evaluate.plot_error(tmp_path / "fig5.png", t, np.abs(np.sin(t)), t < 2, "synthetic", smooth_window=5)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_judges_measure_the_nose_to_the_ball_centre_in_3d():
    ball = np.array([1.0, 0.0, 0.04])
    nose = np.array([[0.0, 0.0, 0.186], [0.85, 0.0, 0.186], [0.9, 0.0, 0.186]])  # last: 0.177 m in 3-D
    assert judges.nose_distance(nose[2], ball) == pytest.approx(np.hypot(0.1, 0.146))
    assert judges.reached(nose, np.tile(ball, (3, 1)))
    assert not judges.reached(nose[:2], np.tile(ball, (2, 1)))  # 0.15 on the floor is 0.209 in 3-D
    assert judges.first_reach_time(np.array([0.0, 0.2, 0.4]), nose, np.tile(ball, (3, 1))) == 0.4
