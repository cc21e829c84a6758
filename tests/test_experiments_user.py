"""The scripted user: teaching schedule and seeded answers to unsure requests."""
import numpy as np
import pytest

from services.experiments.user import ScriptedUser, parse_schedule


def timeline(user, unsure, rate=10.0):
    return [user.teaching(k / rate, u) for k, u in enumerate(unsure)]


def test_schedule_alone_decides_when_no_answers_are_given():
    user = ScriptedUser(schedule=parse_schedule("1-2, 3-3.5"))
    on = timeline(user, [True] * 50)
    expected = [1.0 <= k / 10 < 2.0 or 3.0 <= k / 10 < 3.5 for k in range(50)]
    assert on == expected and user.scheduled_seconds == pytest.approx(1.5)


def test_parse_schedule_explains_a_bad_entry():
    with pytest.raises(ValueError, match=r"schedule entry 'ten' is not 'start-stop'"):
        parse_schedule("0-1,ten")
    with pytest.raises(ValueError, match=r"0 <= start < stop"):
        parse_schedule("5-2")


def test_every_request_answered_at_probability_one_for_answer_seconds():
    user = ScriptedUser(answer_probability=1.0, answer_seconds=0.5)
    unsure = [False] * 5 + [True] * 20 + [False] * 5 + [True] * 3
    on = timeline(user, unsure)
    assert on[:5] == [False] * 5
    assert on[5:10] == [True] * 5 and on[10:25] == [False] * 15  # one request, answered once for 0.5 s
    assert on[30:33] == [True] * 3  # a new request after a confident spell


def test_answers_are_repeatable_by_seed_and_differ_between_seeds():
    rng = np.random.default_rng(0)
    unsure = list(rng.random(2000) < 0.3)
    runs = [timeline(ScriptedUser(answer_probability=0.4, answer_seconds=0.3, seed=s), unsure) for s in (7, 7, 8)]
    assert runs[0] == runs[1] and runs[0] != runs[2]
    assert 0.05 < np.mean(runs[0]) < 0.6


def test_probability_out_of_range_is_refused():
    with pytest.raises(ValueError, match=r"answer_probability must be in \[0, 1\]"):
        ScriptedUser(answer_probability=1.5)


@pytest.mark.slow
def test_in_the_loop_an_untaught_robot_asks_and_the_user_answers():
    """Ball seeking in one process: the lesson is scheduled at 10 s. Untaught, the robot is unsure
    from its first tick; a user who never answers leaves it asking until 10 s, one who always
    answers teaches at once, for answer_seconds (2 s), and again whenever it asks."""
    from services.experiments.ballseek_protocol import run_ballseek

    def run(p):  # LWPR, deterministic in one process: the user's part is what is tested
        r = run_ballseek(0, "lwpr", schedule=((10.0, 15.0),), teach_seconds=5.0, answer_probability=p,
                         n_episodes=0, n_orange=0, correction_seconds=0.0, n_pink_after=0)
        a = r.trace.arrays()
        asked = a["mode"] == "unsure"
        return (r.teaching_seconds, int(np.sum(asked)), float(a["t"][np.argmax(a["teaching"])]),
                a["x"][asked][:, 0].tolist(), np.flatnonzero(asked), a["teaching"])  # a ball in view when it asked?

    assert run(0.0)[:4] == (5.0, 50, 10.0, [0.0] * 50)  # 10 s unsure at 5 Hz, taught only on schedule
    taught, asked, first, balls, when, teaching = run(1.0)
    assert (first, balls[0]) == (0.2, 0.0)  # asked at once, answered from the next tick (no ball in view yet)
    assert asked >= 2 and balls[1:] == [1.0] * (asked - 1)  # asked again only once a ball came into view
    # every request answered, for answer_seconds (2 s, 10 ticks at 5 Hz) each; one may run into the lesson
    assert all(teaching[i + 1:i + 11].all() for i in when)
    assert 5.0 + 2.0 * (asked - 1) <= taught <= 5.0 + 2.0 * asked


@pytest.mark.slow
def test_asked_about_the_orange_ball_a_person_who_answers_corrects_it():
    """Paper V.B and Fig. 4d, in one process: taught with pink only, the student asks for teaching
    whenever the orange ball is in view (and not with pink); a person who teaches only when asked
    corrects it in a few seconds, after which it ignores orange and still seeks pink."""
    from services.experiments.ballseek_protocol import run_ballseek
    from services.experiments.wiring import wired_learner

    learner, params = wired_learner("ballseek")
    r = run_ballseek(0, learner, n_episodes=2, n_orange=3, correction="answers", n_pink_after=2, **params)
    print(f"asks: pink {r.asking('pink alone', 'pink')}, orange {r.asking('orange', 'orange')}; approached "
          f"{r.orange_before}; answered {r.taught_seconds('correction')} s; after: orange {r.orange_after}, "
          f"pink {r.pink_after}, asks {r.asking('orange after', 'orange')}")
    assert r.asking("pink alone", "pink") < 0.1 and r.asking("orange", "orange") > 0.5
    # it walks at orange as at pink, but a far ball can drift out of view on the way and the episode
    # ends searching (which one depends on the last bits of floating point): most, as live
    assert sum(r.orange_before) >= 2
    assert 0.0 < r.taught_seconds("correction") <= 10.0
    assert not any(r.orange_after) and all(t is not None for t in r.pink_after)
    assert r.asking("orange after", "orange") < 0.1
