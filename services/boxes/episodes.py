"""A platform's task reward on the bus: each step's on `dl/<i>/reward` (latest-only, for the page), each
episode's on `dl/<i>/episode` (lossless, for judges), with the steps each command mode drove. For
platforms that report `outcome()` after a step (services.platforms.gym); never a DL input."""
from __future__ import annotations

import collections
import time

from bus_schema import Episode, Reward, encode
from services.bus.publishers import lossless_publisher, sensor_publisher


class EpisodeReporter:
    def __init__(self, session, keys):
        self._reward = sensor_publisher(session, keys.reward)
        self._episode = lossless_publisher(session, keys.episode)
        self._modes: collections.Counter = collections.Counter()
        self.episodes, self.last_return = 0, None

    def stepped(self, tick: int, mode: str, outcome) -> None:
        """After one step driven by the command of `tick` in `mode`, with the platform's outcome (or None)."""
        if outcome is None:
            return
        self._modes[mode] += 1
        self._reward.put(encode(Reward(tick, outcome.episode, outcome.step, outcome.reward, outcome.episode_return,
                                       outcome.done)))
        if outcome.done:
            self._episode.put(encode(Episode(outcome.episode, outcome.step, outcome.episode_return,
                                             outcome.terminated, outcome.truncated, dict(self._modes), time.time())))
            self._modes.clear()
            self.episodes, self.last_return = self.episodes + 1, outcome.episode_return

    def state(self) -> dict:
        """For the platform's status: episodes ended and the last one's return."""
        return {"episodes": self.episodes, "last_return": self.last_return}
