"""The tick path on CPUs of its own (services/placement.py): what a profile's `tick_cpus` asks, refused with the
field named when it cannot be had; which box goes where; a process moved whole, its threads made before included;
a learner learning its history on every CPU it is given, and on the tick path's once it serves live."""
import os
import subprocess
import sys

import numpy as np
import pytest

from rigs.harness import REPO
from services.boxes import BOX_ROLES
from services.placement import (BACKGROUND_ENV, CPUS_ENV, OFF_PATH_BOXES, TICK_PATH_BOXES, Placement, PlacementError,
                                plan, read, spell)
from services.supervisor.profile import ProfileError, load_profile

TWO = {0, 1}


def test_auto_gives_the_tick_path_the_upper_half_and_nothing_on_one_cpu():
    assert plan("auto", TWO) == Placement(frozenset({1}), frozenset({0}))
    assert plan("auto", set(range(8))) == Placement(frozenset({4, 5, 6, 7}), frozenset({0, 1, 2, 3}))
    assert plan("auto", {0, 2, 5}) == Placement(frozenset({5}), frozenset({0, 2}))
    assert plan("auto", {3}) is None, "one CPU: nothing to keep apart"
    assert plan("off", TWO) is None


def test_a_list_is_the_tick_paths_and_the_rest_gets_every_other_cpu():
    assert plan([3], {0, 1, 2, 3}) == Placement(frozenset({3}), frozenset({0, 1, 2}))
    assert plan([0, 2], {0, 1, 2, 3}) == Placement(frozenset({0, 2}), frozenset({1, 3}))


@pytest.mark.parametrize("asked, says", [
    ([], "a list of CPU numbers"), ("fast", "a list of CPU numbers"), (1, "a list of CPU numbers"),
    ([True], "a list of CPU numbers"), ([1.0], "a list of CPU numbers"), ([1, 1], "repeat"),
    ([7], "CPU 7 not among those this process may use (0,1)"), ([0, 1], "leave at least one"),
])
def test_what_cannot_be_had_is_refused_saying_why(asked, says):
    with pytest.raises(PlacementError, match=None) as err:
        plan(asked, TWO)
    assert says in str(err.value)


def test_every_box_is_placed_on_purpose():
    """A new box is put on the tick path or off it by whoever adds it, not by a default."""
    assert TICK_PATH_BOXES | OFF_PATH_BOXES == set(BOX_ROLES) and not TICK_PATH_BOXES & OFF_PATH_BOXES
    placement = plan("auto", TWO)
    for box in BOX_ROLES:
        own = "1" if box in TICK_PATH_BOXES else "0"
        assert placement.env_for(box) == {CPUS_ENV: own, BACKGROUND_ENV: "0"}, box
    with pytest.raises(KeyError):
        placement.env_for("toaster")


def test_cpus_are_read_as_spelled_and_anything_else_is_none():
    assert read("1") == {1} and read("2,3") == {2, 3} and read(spell({3, 2})) == {2, 3}
    assert read("") is None and read(None) is None and read("x") is None and read("1;2") is None


@pytest.mark.parametrize("value, says", [('"fast"', "got 'fast'"), ("[0, 1]", "leave at least one"),
                                         ("[99]", "CPU 99 not among"), ("3", "got 3")])
def test_a_profile_asking_what_cannot_be_had_is_refused_naming_the_field(tmp_path, monkeypatch, value, says):
    # the supervisor as if given CPUs 0 and 1, wherever the test runs (make test's fast tier: on CPU 0 alone)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(TWO))
    profile = tmp_path / "p.toml"
    profile.write_text(f'[profile]\ntick_cpus = {value}\n\n[services.platform]\nbox = "platform"\n')
    with pytest.raises(ProfileError, match=r"^profile\.tick_cpus: ") as err:
        load_profile(profile, check_security=False)
    assert says in str(err.value)
    profile.write_text('[profile]\n\n[services.platform]\nbox = "platform"\n')
    assert load_profile(profile, check_security=False).tick_cpus == "auto"


MASKS = """
import os
def masks():
    return sorted({open(f"/proc/self/task/{t}/status").read().split("Cpus_allowed_list:")[1].split()[0]
                   for t in os.listdir("/proc/self/task")})
"""


def run_python(code: str, env: dict) -> str:
    done = subprocess.run([sys.executable, "-c", MASKS + code], cwd=REPO, env={**os.environ, **env},
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip().splitlines()[-1]


@pytest.mark.live
def test_a_dogged_process_takes_the_cpus_its_supervisor_gave_before_it_has_a_thread_and_its_threads_follow():
    cpu = str(min(os.sched_getaffinity(0)))
    code = "import services, threading, time\nthreading.Thread(target=time.sleep, args=(2,)).start()\nprint(masks())"
    assert run_python(code, {CPUS_ENV: cpu}) == str([cpu])


@pytest.mark.live
def test_a_process_moves_whole_its_threads_made_before_included():
    first = min(os.sched_getaffinity(0))
    code = ("import threading, time\nfrom services.placement import move_process\n"
            "for _ in range(3):\n    threading.Thread(target=time.sleep, args=(2,), daemon=True).start()\n"
            f"print(move_process({{{first}}}), len(os.listdir('/proc/self/task')), masks())")
    assert run_python(code, {CPUS_ENV: ""}) == f"True 4 {[str(first)]}"


def test_a_learner_learns_its_history_on_every_cpu_it_is_given_and_serves_live_on_the_tick_paths(monkeypatch):
    from services.boxes import learner as learner_box
    from tests.test_learner_box import pair
    from tests.test_learner_catch_up import node
    moves = []
    monkeypatch.setattr(learner_box, "to_every_cpu", lambda: moves.append("every"))
    monkeypatch.setattr(learner_box, "take_own_cpus", lambda: moves.append("own"))
    n, _ = node()
    n.replay([pair(s) for s in range(1, 21)])
    n.serve_live_once_caught_up()
    assert moves == [], "not while it has its log to learn"
    n.catch_up(0.0)
    assert moves == ["every"] and n.backlog
    while n.backlog:
        n.catch_up(0.0)
    assert moves == ["every", "own"] and n.serving_live
    n.on_pair(pair(21))  # taught once live: that is the tick path's work, where it is
    n.catch_up(0.0)
    assert moves == ["every", "own"]
    fresh, _ = node("fresh")
    moves.clear()
    fresh.serve_live_once_caught_up()  # nothing to learn first: it stays where it started
    assert moves == ["own"] and np.isfinite(fresh.wait())


@pytest.mark.live
def test_every_cpu_is_its_own_and_the_background_ones():
    cpus = sorted(os.sched_getaffinity(0))
    if len(cpus) < 2:
        pytest.skip("needs two CPUs")
    code = "from services.placement import to_every_cpu\nprint(to_every_cpu(), masks())"
    both = f"{cpus[0]},{cpus[-1]}" if cpus[-1] - cpus[0] > 1 else f"{cpus[0]}-{cpus[-1]}"
    assert run_python(code, {CPUS_ENV: str(cpus[-1]), BACKGROUND_ENV: str(cpus[0])}) == f"True {[both]}"
