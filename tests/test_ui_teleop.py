"""Teleoperation end to end (issue 15, acceptance 3): a scripted person teaches ball seeking for 60 s
only through the page's arrow keys (the ball-seeking teacher's policy pressing keys), then the
student alone seeks the pink ball. deploy/ballseek.toml live, the page in headless chromium."""
import time
from collections import Counter

import pytest

from bus_schema import SpacesMessage, Spaces, TrainingPair, decode
from rigs.harness import free_port, needs_chromium
from rigs.headless import open_page
from rigs.live.page import KeyboardPerson, PageStage, start_ballseek_with_page
from services.bus.queries import ask_owner
from services.demo.live import decoded
from services.experiments import ballseek_protocol as protocol
from services.own_identities import page_address

pytestmark = [pytest.mark.live, needs_chromium]

RATE_HZ = 15.0  # deploy/ballseek.toml's
# the demo's pink episodes, 5 of its 10 (at 80 % as there: 4 of 5): the lesson through the keys is what this
# adds to tests/test_experiments_live.py, and 10 episodes made this the longest test of CI (224 s on a 2-core
# machine where CI took 31 minutes)
TEACH_S, EPISODES, EPISODE_S = 60.0, 5, 30.0


def _handed_over(run, timeout: float = 2.0) -> int:
    """The index of the first command after the keys were released that the teacher did not drive: a
    command already on its way when the key went up is still the teacher's. Within `timeout` seconds."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        modes = [c.mode for c in run.commands()]
        for i in range(len(modes) - 1, -1, -1):
            if modes[i] == "teacher":
                if i + 1 < len(modes):
                    return i + 1
                break
        else:
            return 0
        time.sleep(0.02)
    raise AssertionError(f"the teacher still drove {timeout} s after the keys were released")


def test_a_person_teaches_ball_seeking_with_the_arrow_keys(tmp_path):
    port = free_port()
    run = start_ballseek_with_page(tmp_path / "run", f"tcp/127.0.0.1:{free_port()}", port)
    held = run.record(run.keys.train)
    try:
        payload, problem = ask_owner(run.session, run.keys.spaces, 5.0)
        assert payload is not None, problem
        spaces = Spaces.from_dict(decode(SpacesMessage, payload, run.keys.spaces).spaces)
        with open_page(page_address(port, wait_s=30)) as page:
            page.wait_for_selector("#ears[data-mode]", timeout=30_000)
            stage = PageStage(run, RATE_HZ, KeyboardPerson(page, spaces))
            protocol.teach(stage, True, TEACH_S, seed=0)
            stage.switch(False)
            pairs = (decoded(TrainingPair, k, raw) for k, raw, _ in run.recorded[run.keys.train])
            taught = Counter(p.source for p in pairs if p is not None)
            alone_from = _handed_over(run)
            results = protocol.episodes(stage, 0, "episodes", EPISODES, EPISODE_S, "pink", teaching=False)
            modes = Counter(c.mode for c in run.commands()[alone_from:])
        reached = [r for r in results if r is not None]
        print(f"taught {TEACH_S:.0f} s through the keys ({stage.taught_ticks} ticks with a key held; pairs by "
              f"source {dict(taught)}); alone: reached the pink ball in {len(reached)} of {EPISODES} "
              f"({[None if r is None else round(r, 1) for r in results]} s); modes {dict(modes)}")
        assert set(taught) == {"teacher/person"} and taught["teacher/person"] >= 300, "taught by the keys alone"
        assert modes["teacher"] == 0
        assert len(reached) >= 0.8 * EPISODES
    finally:
        held.undeclare()
        assert run.close() == 0
