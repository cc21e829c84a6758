"""Where a tick's time goes, as an observer on the bus sees it: a client session timestamps (wall clock)
every input, learner proposal and command as it arrives; with the input's own stamp (the platform's
clock when it published) and the platform's measured tick latency, each hop's median follows.

The observer's own receive delay is in every arrival alike, so it cancels in the hops between two
arrivals; the first hop (platform -> bus) and the last (command -> platform) include it once each.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np
import zenoh

from bus_schema import Command, Input, InstanceKeys, Proposal, decode
from services.bus.config import zenoh_config

HOPS = ("platform_to_bus", "learner", "arbitrator", "command_to_platform")
DESCRIBED = {"platform_to_bus": "platform publishes -> input seen on the bus",
             "learner": "input -> learner's proposal (receive, predict, publish)",
             "arbitrator": "proposal -> command (receive, decide, publish)",
             "command_to_platform": "command seen -> platform receives it"}


@dataclass(frozen=True)
class TickSeen:
    """One tick as the observer saw it: the input's stamp (the platform's clock as it published) and the
    wall-clock arrivals here of its input, the learner's proposal and the command (NaN: not seen)."""

    tick: int
    stamp: float
    input_at: float
    proposal_at: float
    command_at: float
    mode: str


class HopObserver:
    def __init__(self, router: str, instance: str = "main"):
        self.keys = InstanceKeys(instance)
        self.session = zenoh.open(zenoh_config(connect=[router], mode="peer"))  # as the services: direct links
        self._seen: list[tuple[str, bytes, float]] = []
        self._lock = threading.Lock()
        self._subs: list = []

    def _on(self, sample) -> None:  # only appends: decoding waits until the run is over
        at = time.time()
        with self._lock:
            self._seen.append((str(sample.key_expr), sample.payload.to_bytes(), at))

    def start(self) -> None:
        """Subscribe (only while observing: an observer is one more subscriber the publishers serve)."""
        with self._lock:
            self._seen.clear()
        self._subs = [self.session.declare_subscriber(k, self._on) for k in
                      (self.keys.input, self.keys.command, self.keys.proposal("learner", "*"))]
        time.sleep(0.5)  # matched before the run begins

    def stop(self) -> list[TickSeen]:
        """Unsubscribe; every tick whose command was seen, in order, with what else was seen of it."""
        for sub in self._subs:
            sub.undeclare()
        self._subs = []
        with self._lock:
            seen = list(self._seen)
        stamp, t_in, t_prop, commands = {}, {}, {}, {}
        for key, raw, at in seen:
            if key == self.keys.input:
                msg = decode(Input, raw, key)
                stamp[msg.tick], t_in[msg.tick] = msg.stamp, at
            elif key == self.keys.command:
                msg = decode(Command, raw, key)
                commands.setdefault(msg.tick, (msg, at))
            else:
                t_prop.setdefault(decode(Proposal, raw, key).tick, at)
        nan = float("nan")
        return [TickSeen(tick, msg.stamp, t_in.get(tick, nan), t_prop.get(tick, nan), at, msg.mode)
                for tick, (msg, at) in sorted(commands.items())]

    def hops_us(self, tick_ms: np.ndarray) -> dict[str, float]:
        """Median microseconds of each hop over the ticks seen whole (input, proposal, command)."""
        return hop_medians_us(self.stop(), tick_ms)

    def close(self) -> None:
        self.session.close()


def hop_medians_us(ticks: list[TickSeen], tick_ms: np.ndarray) -> dict[str, float]:
    """Median microseconds of each hop over `ticks` seen whole; the last hop from the tick's median
    `tick_ms` (as the platform measured it) less the command's median arrival here."""
    whole = [t for t in ticks if not (np.isnan(t.input_at) or np.isnan(t.proposal_at))]
    whole = whole[len(whole) // 20:]  # the first 5 % include connection set-up
    if not whole:
        return {hop: float("nan") for hop in HOPS}
    to_bus = np.median([t.input_at - t.stamp for t in whole])
    learner = np.median([t.proposal_at - t.input_at for t in whole])
    arbitrator = np.median([t.command_at - t.proposal_at for t in whole])
    command_seen = np.median([t.command_at - t.stamp for t in whole])
    back = float(np.median(tick_ms)) / 1e3 - command_seen
    return {hop: round(float(v) * 1e6, 1) for hop, v in zip(HOPS, (to_bus, learner, arbitrator, back))}
