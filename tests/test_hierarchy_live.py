"""deploy/hierarchy.toml as real processes (issue 16, acceptance 2): the walk and seek levels taught
at once for 90 s (their hand-coded teachers on while balls are put down), then both teachers off:
the learned seeking over the learned gait reaches the pink ball in at least 2 of 3 episodes."""
from collections import Counter

import pytest

from rigs.harness import free_port
from rigs.live.hierarchy import TwoLevelStage, seek_alone, start_hierarchy, teach_both

pytestmark = pytest.mark.live

TEACH_S = 90.0


def test_both_learned_levels_reach_the_pink_ball(tmp_path):
    run, walk = start_hierarchy(tmp_path / "run", f"tcp/127.0.0.1:{free_port()}")
    try:
        stage = TwoLevelStage(run, walk)
        teach_both(stage, TEACH_S, seed=0)
        alone_from = (len(run.commands()), len(walk.commands()))
        results = seek_alone(stage, 3, seed=0)
        seek_modes = Counter(c.mode for c in run.commands()[alone_from[0]:])
        walk_modes = Counter(c.mode for c in walk.commands()[alone_from[1]:])
        print(f"taught {TEACH_S:.0f} s; reached after {results} s; seek {dict(seek_modes)}, walk {dict(walk_modes)}")
        assert seek_modes["teacher"] == 0 and walk_modes["teacher"] == 0, "both teachers off"
        assert walk_modes["student"] >= 0.8 * sum(walk_modes.values()), "the learned gait walked"
        assert sum(r is not None for r in results) >= 2
    finally:
        walk.close()
        assert run.close() == 0
