import numpy as np

from bus_schema import TrainingPair
from bus_schema.teachers import sources_of
from services.pairlog import PairLog


def test_pairs_survive_a_restart_and_a_torn_tail(tmp_path):
    path = tmp_path / "l.pairs"
    log = PairLog(2, 1, path)
    assert log.replay_file() == []
    for i in range(5):
        x, y = np.full(2, i, float), np.full(1, -i, float)
        log.append(TrainingPair("e", i + 1, i, x, y, "teacher/t"))
    log.close()
    with open(path, "ab") as f:
        f.write(b"\x87\xa1v")  # a record cut short by a crash
    again = PairLog(2, 1, path)
    pairs = again.replay_file()
    assert [p.seq for p in pairs] == [1, 2, 3, 4, 5]
    assert again.history()[0][:, 0].tolist() == [0, 1, 2, 3, 4], "replayed pairs are history too"
    assert path.stat().st_size == sum(len(__import__("bus_schema").encode(p)) for p in pairs)


def test_history_reads_back_from_the_file_and_memory_holds_no_pairs():
    """The pair log kept every pair in memory for the life of the learner (hours of teaching at 100 Hz
    on 18 joints: hundreds of MB); it now keeps them in its file, a temporary one without a state dir."""
    log = PairLog(3, 2)
    for i in range(3000):
        mask = np.array([1.0, 0.0]) if i % 7 == 0 else None
        source = "teacher/p" if i % 5 == 0 else "teacher/t"
        log.append(TrainingPair("e", i + 1, i, np.full(3, i, float), np.full(2, -i, float), source, mask))
    x, y, mask, teachers, teacher_of = log.history()
    assert len(log) == 3000 and x.shape == (3000, 3) and x[2999, 0] == 2999 and y[10, 1] == -10
    assert mask[7].tolist() == [1.0, 0.0] and mask[8].tolist() == [1.0, 1.0]
    assert sources_of(teachers, teacher_of)[:6] == ["teacher/p"] + ["teacher/t"] * 4 + ["teacher/p"]
    assert log.history(5)[0][:, 0].tolist() == [0, 1, 2, 3, 4]
    assert all(not isinstance(v, np.ndarray) or v.size < 100 for v in vars(log).values())
    scratch = log.rows_path
    log.close()
    assert not scratch.exists(), "the temporary pair file goes with the learner"
