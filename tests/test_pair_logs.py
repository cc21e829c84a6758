"""At `dogged up`, a learner starts from the log of whichever of its swaps served last (services/supervisor/
pair_logs.py): before, the next run's learner read only the log of the learner the first swap retired, and
everything taught since was forgotten. Every log replaced is kept. Live: tests/test_swap_then_up.py."""
import os

from services.supervisor.pair_logs import adopt_successor_log, set_aside_stale_log


def logs(tmp_path, **ages):
    """Files <name>.pairs holding their name, written `age` seconds ago."""
    for name, age in ages.items():
        f = tmp_path / f"{name}.pairs"
        f.write_text(name)
        os.utime(f, ns=(1_700_000_000_000_000_000 - age * 10**9,) * 2)


def names(tmp_path):
    return sorted(f.name.split(".pairs")[0] + (".earlier" if f.name.endswith(".earlier") else "")
                  for f in tmp_path.iterdir())


def test_the_swap_that_wrote_last_becomes_the_learners_log_and_the_others_are_kept_aside(tmp_path):
    logs(tmp_path, **{"learner": 300, "learner-s1": 200, "learner-s2": 100, "learner2-s3": 1})
    assert adopt_successor_log(tmp_path, "learner") == "learner-s2.pairs"
    assert (tmp_path / "learner.pairs").read_text() == "learner-s2"
    assert names(tmp_path) == ["learner", "learner-s1.earlier", "learner.earlier", "learner2-s3"]


def test_its_own_log_stays_when_it_was_written_after_every_swap(tmp_path):
    logs(tmp_path, **{"learner": 10, "learner-s1": 200})  # a swap that failed: the old learner went on
    assert adopt_successor_log(tmp_path, "learner") is None
    assert (tmp_path / "learner.pairs").read_text() == "learner"
    assert names(tmp_path) == ["learner", "learner-s1.earlier"]


def test_a_swap_with_no_log_of_its_own_before_is_adopted_and_nothing_else_moves(tmp_path):
    logs(tmp_path, **{"learner-s4": 5})
    assert adopt_successor_log(tmp_path, "learner") == "learner-s4.pairs"
    assert names(tmp_path) == ["learner"]
    assert adopt_successor_log(tmp_path, "learner") is None and adopt_successor_log(tmp_path / "none", "x") is None


def test_a_stale_log_under_a_new_swaps_name_is_set_aside_and_two_in_a_second_both_kept(tmp_path):
    for _ in range(2):
        logs(tmp_path, **{"learner-s1": 5})
        set_aside_stale_log(tmp_path, "learner-s1")
    assert names(tmp_path) == ["learner-s1.earlier", "learner-s1.earlier"]
