import numpy as np

from bus_schema import TrainingPair
from services.pairlog import PairLog


def test_pairs_survive_a_restart_and_a_torn_tail(tmp_path):
    path = tmp_path / "l.pairs"
    log = PairLog(2, 1, path)
    assert log.replay_file() == []
    for i in range(5):
        x, y = np.full(2, i, float), np.full(1, -i, float)
        log.append(x, y, TrainingPair("e", i + 1, i, x, y, "teacher/t"))
    log.close()
    with open(path, "ab") as f:
        f.write(b"\x87\xa1v")  # a record cut short by a crash
    again = PairLog(2, 1, path)
    pairs = again.replay_file()
    assert [p.seq for p in pairs] == [1, 2, 3, 4, 5]
    assert path.stat().st_size == sum(len(__import__("bus_schema").encode(p)) for p in pairs)


def test_growth_keeps_rows():
    log = PairLog(3, 2)
    for i in range(3000):
        log.append(np.full(3, i), np.full(2, i))
    assert len(log) == 3000 and log.x[2999, 0] == 2999 and log.y.shape == (3000, 2)
