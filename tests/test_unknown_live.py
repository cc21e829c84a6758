"""A task nobody designed, taught live (issue 11): a teacher of a random curved map from the tail's
two joints onto the head's two joints, on the mirroring profile as real processes, switched on and
off as a person would; the wired learner must then do it alone, inside the output space."""
import pytest

from bus_schema.spaces import Spaces
from rigs.harness import free_port
from rigs.live.fits import wait_caught_up
from rigs.live.mirroring import RATE, start_mirroring, student_error
from services.platforms.aibo.platform import JOINTS_BOX
from services.teachers import make_teacher

pytestmark = pytest.mark.live

MAP = {"seed": 3, "inputs": [16, 17], "outputs": [12, 13], "span": 1.3}


def test_a_random_head_map_taught_for_30_s_is_done_alone(tmp_path):
    run = start_mirroring(tmp_path, f"tcp/127.0.0.1:{free_port()}", teachers={"stranger": ("random-map", MAP)})
    try:
        run.run_ticks(30)
        run.teach(True)
        run.run_ticks(int(30 * RATE))
        run.teach(False)
        waited = wait_caught_up(run)  # the fits on their own thread: on 2 busy cores they may lag
        off = run.tick()
        run.run_ticks(int(15 * RATE))
        error, n = student_error(run, off + 3, teacher=make_teacher("random-map", Spaces(JOINTS_BOX, JOINTS_BOX),
                                                                    **MAP))
        commands = run.commands()
    finally:
        assert run.close() == 0
    modes = [c.mode for c in commands if c.tick > off + 3]
    print(f"random head map live: RMS {error:.4f} rad over {n} student ticks; "
          f"unsure {modes.count('unsure') / max(1, len(modes)):.0%}; {len(commands)} commands; fits caught up "
          f"{waited:.1f} s after the lesson")
    assert n >= 300 and error < 0.1
    assert all(JOINTS_BOX.contains(c.y) for c in commands)
