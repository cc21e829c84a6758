"""Two levels of Dogged Learning on one Aibo, as processes (deploy/hierarchy.toml itself): both
levels taught at once, their hand-coded teachers on while a person puts the pink ball down in fresh
arenas (the seek teacher asks for the movements the walk level learns), then both teachers off and
the two students seek the ball alone. Used by tests/test_hierarchy_live.py and benchmarks/hierarchy.py.
"""
from __future__ import annotations

from pathlib import Path

from rigs.harness import REPO
from services.demo.ballseek import LiveStage
from services.demo.live import BusRecorder, LiveRun, when_ready
from services.experiments import ballseek_protocol as protocol
from services.experiments.hierarchy import EPISODE_SECONDS

PROFILE = REPO / "deploy" / "hierarchy.toml"
SEEK, WALK = "seek", "walk"
SEEK_RATE_HZ = 15.0  # the seek level's ticks: the camera's frames, in simulated time


def profile_in(run_dir: Path) -> Path:
    """deploy/hierarchy.toml with its logs and the learners' state under `run_dir`."""
    text = PROFILE.read_text()
    head = "[profile]\n"
    if text.count(head) != 1 or "runs/hierarchy/state" not in text:
        raise ValueError(f"{PROFILE} no longer has one [profile] table and runs/hierarchy/state: update profile_in")
    text = text.replace(head, f'{head}log_dir = "{run_dir / "logs"}"\nstate_dir = "{run_dir / "state"}"\n')
    path = run_dir / "hierarchy.toml"
    path.write_text(text.replace("runs/hierarchy/state", str(run_dir / "state")))
    return path


class TwoLevelStage(LiveStage):
    """The ball-seeking stage (clock: the seek level's ticks) whose teaching switch turns both levels'
    teachers on or off together."""

    def __init__(self, run: LiveRun, walk: BusRecorder):
        super().__init__(run, SEEK_RATE_HZ)
        self.walk = walk

    def switch(self, on: bool) -> None:
        if on != self.teaching:
            self.walk.teach(on)
        super().switch(on)


def start_hierarchy(run_dir: Path, endpoint: str) -> tuple[LiveRun, BusRecorder]:
    run_dir.mkdir(parents=True, exist_ok=True)
    run = when_ready(LiveRun(profile_in(run_dir), run_dir, endpoint, instance=SEEK))
    try:
        return run, BusRecorder(endpoint, instance=WALK)
    except BaseException:
        run.close()
        raise


def teach_both(stage: TwoLevelStage, seconds: float, seed: int) -> None:
    """Both teachers on for `seconds`, a fresh arena and ball spot each time the ball is reached or
    after 15 s; the teachers off at the end."""
    protocol.teach(stage, True, seconds, seed)
    stage.switch(False)


def seek_alone(stage: TwoLevelStage, episodes: int, seed: int) -> list[float | None]:
    """`episodes` of EPISODE_SECONDS with the pink ball in view, the two students alone: the time
    each reached it, or None."""
    return protocol.episodes(stage, seed, "episodes", episodes, EPISODE_SECONDS, "pink")
