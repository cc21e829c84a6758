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


def test_the_figure5_measure_runs_the_teacher_on_the_students_inputs_scaled_by_half_the_range():
    from bus_schema.spaces import Box
    scale = evaluate.half_range(Box((-1.0,), (3.0,)))
    teacher_y, error = evaluate.figure5_error(HalfTeacher(), np.array([[2.0], [4.0]]), np.array([[0.0], [3.0]]),
                                              scale=scale)
    assert scale.tolist() == [2.0] and teacher_y[:, 0].tolist() == [1.0, 2.0]
    np.testing.assert_allclose(error, [0.5, 0.5])


def test_error_over_time_is_rms_over_chosen_outputs_with_scale():
    teacher = np.array([[1.0, 0.0, 5.0], [0.0, 0.0, 0.0]])
    student = np.array([[0.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    np.testing.assert_allclose(evaluate.error_over_time(teacher, student, outputs=[0, 1]), [np.sqrt(0.5), np.sqrt(2)])
    np.testing.assert_allclose(evaluate.error_over_time(teacher, student, scale=[1, 2, 5]), [np.sqrt(2 / 3),
                                                                                             np.sqrt(1 / 3)])


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


def band_columns(path) -> dict:
    """Per band colour, the image columns it covers: (first, last, how many), read from the PNG's pixels
    on the rows the band crosses (a legend's swatch is too narrow to count)."""
    import cv2

    img = cv2.imread(str(path)).astype(int)
    green, red = img[..., 1], img[..., 2]
    out = {}
    for name, mask in (("teacher", (red - green > 15) & (red > 200)), ("asking", green - red > 40)):
        rows = mask.sum(axis=1) >= 50
        columns = np.flatnonzero(mask[rows].mean(axis=0) > 0.5) if rows.any() else np.array([], int)
        out[name] = (int(columns.min()), int(columns.max()), len(columns)) if len(columns) else None
    return out


def test_the_figure_shades_where_the_teacher_spoke_and_marks_where_the_robot_asked(tmp_path):
    """Teacher on for t < 2 s, the robot asking for t > 3 s, over 0..5 s: the shading and the strip sit
    where they should, read from the PNG's pixels."""
    t = np.arange(500) / 100.0
    path = evaluate.plot_error(tmp_path / "fig5.png", t, np.abs(np.sin(t)) / 2, t < 2, "synthetic", asking=t > 3)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bands = band_columns(path)
    (left, teacher_end, teacher_n), (asking_start, right, asking_n) = bands["teacher"], bands["asking"]
    assert teacher_n == teacher_end - left + 1 and asking_n == right - asking_start + 1, "each band is one span"
    width = right - left  # the teacher band starts at t=0, the asking strip ends at t=4.99: the axes
    assert abs((teacher_end - left) / width - 2 / 4.99) < 0.02
    assert abs((asking_start - left) / width - 3 / 4.99) < 0.02
    quiet = evaluate.plot_error(tmp_path / "quiet.png", t, np.abs(np.sin(t)) / 2, t < 0, "synthetic")
    assert band_columns(quiet) == {"teacher": None, "asking": None}


def test_moving_average_is_trailing():
    np.testing.assert_allclose(evaluate.moving_average(np.array([2.0, 4.0, 6.0, 8.0]), 2), [2.0, 3.0, 5.0, 7.0])


def test_judges_measure_the_nose_to_the_ball_centre_in_3d():
    ball = np.array([1.0, 0.0, 0.04])
    nose = np.array([[0.0, 0.0, 0.186], [0.85, 0.0, 0.186], [0.9, 0.0, 0.186]])  # last: 0.177 m in 3-D
    assert judges.nose_distance(nose[2], ball) == pytest.approx(np.hypot(0.1, 0.146))
    assert judges.reached(nose, np.tile(ball, (3, 1)))
    assert not judges.reached(nose[:2], np.tile(ball, (2, 1)))  # 0.15 on the floor is 0.209 in 3-D
    assert judges.first_reach_time(np.array([0.0, 0.2, 0.4]), nose, np.tile(ball, (3, 1))) == 0.4
