"""The platform box: puts any Platform (services.platforms) on the bus.

At the control rate it publishes the input, applies the freshest command (latest-only) and
reports what it applied; with no fresh command for `watchdog` seconds it holds still. With
rate 0 it runs in lockstep, as fast as the loop answers (simulated time still advances 1/sim_hz
per tick). It measures each tick's latency: input published -> its command received.
"""
from __future__ import annotations

import argparse
import collections
import json
import time
from pathlib import Path

import numpy as np
import zenoh

from bus_schema import Applied, Command, InstanceKeys, Input, SpacesMessage, encode
from bus_schema.spaces import announced
from services.boxes.numbers import COUNT, POSITIVE_HZ, RATE_HZ, SECONDS
from services.boxes.episodes import EpisodeReporter
from services.bus.config import add_bus_args, config_from_args
from services.bus.inbox import decode_or_reject
from services.bus.runtime import BoxRuntime
from services.params import parse_params
from services.platforms import PLATFORMS, make_platform

SUBSCRIPTION_SETTLE_S = 0.3
ANSWER_WINDOW = 1000  # ticks: a command later than this is counted as never having come
LATENCY_WINDOW_S = 10.0  # the status's latency percentiles: the commands of the last 10 s (at most 4000)


class PlatformLoop:
    """Ticks, commands, the watchdog and latency for one Platform, on its box's runtime; subclasses add streams."""

    def __init__(self, box: BoxRuntime, platform, latency_log=None):
        self.box, self.keys, self.platform, self.log, self.name = box, box.keys, platform, box.log, box.name
        self.dims = platform.spaces.output.dims
        self.input_pub = box.sensor_publisher(self.keys.input)
        self.applied_pub = box.sensor_publisher(self.keys.applied)
        self.rejects, self.counts = box.rejects, box.counts
        self.tick = 0
        self.due_at = 0.0  # (monotonic) when the next input goes out
        self.after_tick_at: float | None = None  # the tick's other streams go out by then at the latest (after_tick)
        self.latest: Command | None = None
        self.latest_at = -1.0
        self.applied_tick = -1
        self.latencies: list[float] = [] if latency_log else None
        self.recent_latency = collections.deque(maxlen=4000)  # (arrival monotonic, latency s)
        self.answered: set[int] = set()       # ticks still in the window that got a command
        self.n_answered, self.unanswered = 0, []  # ticks that left the window (first 1000 misses kept)
        self.last_unanswered = collections.deque(maxlen=1000)  # and the latest 1000: no late miss hides
        self.n_unanswered = 0
        self.mode = ""
        # a platform with a task's reward (gym) reports each step's outcome: the reward goes on its own keys
        self.episodes = EpisodeReporter(box.session, box.keys) if callable(getattr(platform, "outcome", None)) else None

    def next_tick(self) -> int:
        """A new tick: the oldest one leaves the answer window."""
        self.tick += 1
        self._settle(self.tick - ANSWER_WINDOW)
        return self.tick

    def publish_input(self):
        self.input_pub.put(encode(Input(self.next_tick(), time.time(), self.platform.observe())))
        self.counts["inputs"] += 1

    def _settle(self, tick: int) -> None:
        """A tick leaves the window: answered or not, for good (memory stays bounded on long runs)."""
        if tick < 1:
            return
        if tick in self.answered:
            self.answered.discard(tick)
            self.n_answered += 1
        else:
            self.n_unanswered += 1
            self.last_unanswered.append(tick)
            if len(self.unanswered) < 1000:
                self.unanswered.append(tick)

    def on_command(self, key, raw):
        msg = decode_or_reject(Command, raw, key, self.rejects, {"y": self.dims})
        if msg is None:
            return
        if not 1 <= msg.tick <= self.tick:
            # an answer to an input never published: trusted, it would outrank every real command and
            # the watchdog would hold the robot still until a restart
            self.rejects(key, ValueError(f"a command for tick {msg.tick}, which this platform has not published "
                                         f"(its last tick is {self.tick})"))
            return
        self.counts["commands"] += 1
        if msg.tick < self.tick:  # the answer came after the next input went out
            self.counts["stale_commands"] += 1
        if self.tick - ANSWER_WINDOW < msg.tick <= self.tick:
            self.answered.add(msg.tick)
        latency = time.time() - msg.stamp
        self.recent_latency.append((time.monotonic(), latency))
        if self.latencies is not None:
            self.latencies.append(latency)
        if self.latest is None or msg.tick > self.latest.tick:
            self.latest, self.latest_at = msg, time.monotonic()
        if msg.mode != self.mode:
            self.mode = msg.mode
            self.show_mode(msg.mode)

    def show_mode(self, mode: str) -> None:
        """The robot shows the arbitrator's mode (the Aibo's ears); plain platforms have nothing to show."""

    def after_tick(self) -> None:
        """What the robot says besides its input (the Aibo's camera, clock and state): run once the tick is
        answered, or half a period on, so that none of it delays the input's way to its command."""

    def advance(self, dt, watchdog):
        fresh = self.latest is not None and self.latest.tick > self.applied_tick \
            and time.monotonic() - self.latest_at <= watchdog
        if fresh:
            applied = self.platform.step(self.latest.y, dt)
            self.applied_tick = self.latest.tick
            self.applied_pub.put(encode(Applied(self.latest.tick, applied, False)))
            self.counts["applied"] += 1
            self._stepped()
        elif self.latest is not None and time.monotonic() - self.latest_at <= watchdog:
            self.platform.step(self.latest.y, dt)  # late answer, watchdog not fired: keep the last command
            self._stepped()
        else:
            self.platform.hold(dt)  # watchdog: nothing fresh, hold still
            self.counts["held"] += 1

    def _stepped(self) -> None:
        if self.episodes is not None:
            self.episodes.stepped(self.latest.tick, self.latest.mode, self.platform.outcome())

    def summary(self) -> dict:
        window = range(max(1, self.tick - ANSWER_WINDOW + 1), self.tick + 1)
        in_window = [t for t in window if t not in self.answered]
        answered = self.n_answered + len(self.answered)
        return {"ticks": self.tick, "commands": self.counts["commands"], "answered": answered,
                "unanswered": self.n_unanswered + len(in_window),
                "first_unanswered": (self.unanswered + in_window)[:1000],
                "last_unanswered": (list(self.last_unanswered) + in_window)[-1000:],
                "held": self.counts["held"], "applied": self.counts["applied"], "rejected": self.rejects.total}

    def tick_answered(self) -> bool:
        """Whether the newest tick has its command."""
        return self.latest is not None and self.latest.tick >= self.tick

    def wait(self) -> float:
        wake = self.due_at if self.after_tick_at is None else min(self.due_at, self.after_tick_at)
        return max(0.0, wake - time.monotonic())

    def finish_tick(self) -> None:
        self.after_tick()
        self.after_tick_at = None

    def report(self):
        since = time.monotonic() - LATENCY_WINDOW_S
        lat = np.array([ms for at, ms in self.recent_latency if at >= since] or [0.0]) * 1e3
        # lost: ticks that left the answer window unanswered
        counters = {"tick": self.tick, "lost_ticks": self.n_unanswered}
        if hasattr(self.platform, "clipped_inputs"):  # observations beyond the declared bounds (gym)
            counters["clipped_inputs"] = self.platform.clipped_inputs
        state = {"mode": self.mode, **(self.episodes.state() if self.episodes else {}),
                 "latency_p50_ms": round(float(np.percentile(lat, 50)), 3),
                 "latency_p99_ms": round(float(np.percentile(lat, 99)), 3)}
        return counters, state


def run_ticks(loop: PlatformLoop, handlers: dict, rate_hz: float, sim_hz: float, watchdog: float,
              max_ticks: int, spaces_key: str | None = None, command_from: str | None = None) -> None:
    """The platform's clock: ticks at `rate_hz` (0: lockstep, the next tick as soon as this one is
    answered), applies commands, holds under the watchdog, and serves the spaces query."""
    box = loop.box
    spaces_payload = encode(SpacesMessage(announced(loop.platform.spaces, rate_hz).to_dict()))
    spaces_key = box.keys.spaces if spaces_key is None else spaces_key  # "": another box owns the spaces
    # chained instances: the robot obeys the lowest instance's commands (dl/<lower>/command) and
    # waits for that instance's arbitrator
    commander = InstanceKeys(command_from) if command_from else box.keys
    box.subscribe(commander.command, "command")
    box.subscribe_alive(f"{commander.prefix}/alive/commanding/*", "arbitrator")
    if spaces_key:
        box.queryable(spaces_key, "spaces")
    period = 1.0 / rate_hz if rate_hz else None
    dt = period or 1.0 / sim_hz
    loop.due_at = time.monotonic()
    # our command subscription reaches the arbitrator a moment after we declare it: the first tick
    # waits for a commanding arbitrator and for that moment, so no command goes where we are not yet
    settled_at = loop.due_at + SUBSCRIPTION_SETTLE_S
    arbitrators: set[str] = set()
    for batch in box.batches(loop.wait, loop.report):  # the tick first; the batch waits until the next is due
        now = time.monotonic()
        waiting = loop.tick == 0 and (not arbitrators or now < settled_at)  # hold still, lose no tick
        if waiting:
            loop.due_at = now + 0.05
        answered = loop.tick_answered()
        if max_ticks and loop.tick >= max_ticks and (answered or now >= loop.due_at + watchdog):
            break  # the last tick is answered (or will never be): done
        if not waiting and (now >= loop.due_at or (period is None and answered)):
            if loop.after_tick_at is not None:  # never skipped: a tick's streams go out before the next tick
                loop.finish_tick()
            if loop.tick:
                loop.advance(dt, watchdog)
            if not (max_ticks and loop.tick >= max_ticks):
                loop.publish_input()
            loop.after_tick_at = time.monotonic() + (period or watchdog) / 2  # from the input, not the physics before
            # rate mode keeps a steady cadence (no burst after a stall); lockstep waits for the answer
            loop.due_at = max(loop.due_at + period, now) if period else now + watchdog
        for tag, key, raw, kind in batch:
            if tag == "spaces":
                raw.reply(spaces_key, spaces_payload)
            elif tag == "arbitrator":
                (arbitrators.add if kind == zenoh.SampleKind.PUT else arbitrators.discard)(key)
            elif tag == "command":
                loop.on_command(key, raw)
            else:
                handlers[tag](key, raw)
        if loop.after_tick_at is not None and (loop.tick_answered() or time.monotonic() >= loop.after_tick_at):
            loop.finish_tick()


def finish(loop: PlatformLoop, latency_log: str | None, summary: str | None) -> None:
    if latency_log:
        np.save(latency_log, np.array(loop.latencies))
    if summary:
        Path(summary).write_text(json.dumps(loop.summary()))
    loop.log.info("stopping after %d ticks, %d commands", loop.tick, loop.counts["commands"])


def main(conf: zenoh.Config, instance: str, platform: str, params: dict, name: str = "platform",
         rate_hz: float = 30.0, sim_hz: float = 30.0, watchdog: float = 0.5, max_ticks: int = 0,
         latency_log: str | None = None, summary: str | None = None, command_from: str | None = None) -> int:
    box = BoxRuntime(conf, InstanceKeys(instance), "platform", name)  # (stopped by a signal while the robot is made)
    with make_platform(platform, **params) as robot, box:
        loop = PlatformLoop(box, robot, latency_log)
        box.log.info("%s platform: %d inputs, %d outputs, %s", platform, robot.spaces.input.dims,
                     robot.spaces.output.dims, f"{rate_hz} Hz" if rate_hz else "lockstep")
        run_ticks(loop, {}, rate_hz, sim_hz, watchdog, max_ticks, command_from=command_from)
        finish(loop, latency_log, summary)
    return 0


def arg_parser() -> argparse.ArgumentParser:
    """The one reading of `dogged run platform`'s arguments (a profile's are read with it too)."""
    parser = argparse.ArgumentParser(prog="dogged run platform", description=__doc__.splitlines()[0])
    parser.add_argument("--instance", default="main")
    parser.add_argument("--name", default="platform")
    parser.add_argument("--platform", choices=sorted(PLATFORMS), default="point")
    parser.add_argument("--param", action="append", help="platform parameter name=value (repeatable)")
    parser.add_argument("--rate", type=RATE_HZ, default=30.0,
                        help="control rate in Hz; 0 = lockstep, as fast as answered")
    parser.add_argument("--sim-hz", type=POSITIVE_HZ, default=30.0, help="simulated ticks per second in lockstep")
    parser.add_argument("--watchdog", type=SECONDS, default=0.5,
                        help="seconds without a fresh command before holding still")
    parser.add_argument("--max-ticks", type=COUNT, default=0, help="stop after this many ticks (0: run until stopped)")
    parser.add_argument("--latency-log", default=None, help="save every tick latency (s) to this .npy file at exit")
    parser.add_argument("--summary", default=None, help="write tick counts (JSON) to this file at exit")
    parser.add_argument("--command-from", default=None, metavar="INSTANCE",
                        help="obey this instance's commands (the lowest of a chain); default: our own")
    add_bus_args(parser)
    return parser


def cli(argv=None) -> int:
    parser = arg_parser()
    args = parser.parse_args(argv)
    return main(config_from_args(args), args.instance, args.platform, parse_params(args.param), args.name,
                args.rate, args.sim_hz, args.watchdog, args.max_ticks, args.latency_log, args.summary,
                args.command_from)
