"""The paper's experiments, shortened, with real processes: the learned behaviour is asserted."""
import numpy as np
import pytest

from services.demo.ballseek import run_ballseek_live
from services.demo.mirroring import RATE, start_mirroring, student_error
from tests.harness import free_port


def endpoint():
    return f"tcp/127.0.0.1:{free_port()}"


def test_mirroring_one_teacher_live(tmp_path):
    run = start_mirroring(tmp_path, endpoint(), learner="lwpr")
    try:
        run.run_ticks(30)
        untaught, _ = student_error(run, 0)
        run.teach(True)
        run.run_ticks(int(10 * RATE))           # 10 s of teaching (the paper: under 10 s)
        run.teach(False)
        off = run.tick()
        run.run_ticks(int(5 * RATE))            # 5 s of the student alone, the tail still moving
        error, n = student_error(run, off + 3)
    finally:
        assert run.close() == 0
    print(f"mirroring live: untaught RMS {untaught:.3f} rad, after 10 s of teaching {error:.5f} rad over {n} ticks")
    assert n >= 100 and error < 0.1 < untaught


@pytest.mark.parametrize("learner", ["lwpr"])
def test_ballseek_live_student_reaches_the_ball(tmp_path, learner):
    summary = run_ballseek_live(tmp_path, endpoint(), learner=learner, episodes=3, log=print)
    assert summary["supervisor_exit"] == 0
    assert summary["successes"] >= 2, summary
    assert (tmp_path / "figure5.png").stat().st_size > 10_000
    data = np.load(tmp_path / "run.npz")
    first_teach = np.flatnonzero(data["teaching"])[:25]
    # Figure 5: the error falls while the teacher is active
    assert summary["error_student"] < 0.25 and np.mean(data["error"][first_teach[:5]]) > summary["error_teaching"]


def test_mirroring_two_teachers_in_turn_merge_live(tmp_path):
    """Pan is taught, then tilt, by two partial teachers; the student then mirrors both axes."""
    run = start_mirroring(tmp_path, endpoint(), learner="per-output", learner_params={"base": "lwpr"},
                          teachers={"pan": "pan", "tilt": "tilt"})
    try:
        run.run_ticks(30)
        for teacher in ("pan", "tilt"):
            run.teach(True, teacher)
            run.run_ticks(int(10 * RATE))
            run.teach(False, teacher)
        off = run.tick()
        run.run_ticks(int(5 * RATE))
        pan, n = student_error(run, off + 3, axes=("pan",))
        tilt, _ = student_error(run, off + 3, axes=("tilt",))
    finally:
        assert run.close() == 0
    print(f"two teachers in turn, live: student RMS pan {pan:.4f} rad, tilt {tilt:.4f} rad over {n} ticks")
    assert n >= 100 and pan < 0.05 and tilt < 0.05


def test_orange_ball_approached_untaught_then_ignored_after_correction_live(tmp_path):
    """Paper V.B's emergent behaviour, with the colour-blind blob slots (docs/results.md)."""
    from services.demo.ballseek import ball_episodes, correct_orange, start_ballseek, teach_phase
    from services.experiments.ballseek import BALLSEEK_RATE_HZ as rate
    from services.experiments.ballseek_protocol import ORANGE_FAR, TEACHING_SCHEDULE
    run = start_ballseek(tmp_path, endpoint(), layout="slots")
    try:
        teach_phase(run, TEACHING_SCHEDULE, 0, rate)
        before = ball_episodes(run, 3, 20.0, 0, "orange_before", rate, target="orange", far=ORANGE_FAR)
        correct_orange(run, 20.0, 0, rate)
        after = ball_episodes(run, 3, 20.0, 0, "orange_after", rate, target="orange", far=ORANGE_FAR)
    finally:
        assert run.close() == 0
    approached = [sum(r is not None for r in rs) for rs in (before, after)]
    print(f"orange live: approached {approached[0]}/3 before correction, {approached[1]}/3 after")
    assert approached[0] >= 2 and approached[1] == 0
