"""Where a recorded run's episodes begin: at each restart of its platform always, and where the run says
(`--episode-by`): the Gymnasium platform's episodes, the robot's arena resets, or teaching spans (each
stretch the teacher drove, and each it did not, is an episode)."""
from __future__ import annotations

import numpy as np

from services.export.ticks import ExportError, TickTable

EPISODE_BY = ("auto", "gym", "arena", "teaching", "run")


def chosen(table: TickTable, by: str) -> str:
    """`by` itself, or for "auto": gym if the platform reported episodes, else arena if the arena was reset,
    else run."""
    if by not in EPISODE_BY:
        raise ExportError(f"--episode-by {by!r}: expected one of {', '.join(EPISODE_BY)}")
    if by != "auto":
        return by
    if table.gym_episode is not None:
        return "gym"
    return "arena" if table.arena_resets else "run"


def episode_starts(table: TickTable, by: str) -> np.ndarray:
    """(n,) bool: whether each row begins an episode (the first row always does)."""
    starts = np.zeros(len(table), dtype=bool)
    starts[0] = True
    starts[1:] |= table.runs[1:] != table.runs[:-1]
    if by == "gym":
        if table.gym_episode is None:
            raise ExportError("--episode-by gym: the run has no Gymnasium episodes (no dl/<instance>/reward "
                              "recorded: was its platform the gym platform?)")
        episode = _carried(table.gym_episode)
        starts[1:] |= episode[1:] != episode[:-1]
    elif by == "arena":
        if not table.arena_resets:
            raise ExportError("--episode-by arena: the run has no arena reset recorded "
                              f"(robot/{table.robot or '<robot>'}/arena)")
        # the first input received after a reset is the new arena's
        after = np.searchsorted(table.log_ns, table.arena_resets, side="right")
        starts[after[after < len(table)]] = True
    elif by == "teaching":
        taught = table.modes == "teacher"
        starts[1:] |= taught[1:] != taught[:-1]
    return starts


def _carried(episode: np.ndarray) -> np.ndarray:
    """Each row's episode, a row with none (-1: its step was not recorded) taking the last one before it."""
    known = np.where(episode >= 0, np.arange(len(episode)), -1)
    last = np.maximum.accumulate(known)
    return np.where(last >= 0, episode[last.clip(0)], -1)


def episode_index(starts: np.ndarray) -> np.ndarray:
    return np.cumsum(starts) - 1
