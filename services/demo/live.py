"""A live run: a profile brought up by the supervisor, watched and steered over the bus the way
a person (or a scripted user) would: teachers on and off, arena resets, everything recorded.

Used by `dogged demo`, and by the tests' and benchmarks' live runs of the other experiments (rigs/live).
"""
from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import zenoh

from bus_schema import (ArenaReset, Command, Input, InstanceKeys, Proposal, RobotKeys, RobotState, TeachSwitch,
                        decode, decoded, encode)
from services.bus.config import zenoh_config
from services.bus.publishers import lossless_publisher, wait_matching
from services.supervisor.commands import wait_announced
from services.waiting import poll

REPO = Path(__file__).resolve().parents[2]


def switch_teaching(session: zenoh.Session, publisher: zenoh.Publisher, keys: InstanceKeys, on: bool,
                    teacher: str = "") -> None:
    """As a person's switch on the page: teaching on or off (`teacher`, or every teacher), on `publisher` (lossless, on
    keys.teach), done when the teaching tokens say so; a TimeoutError if they do not within 10 s."""
    wait_matching(publisher, 5.0)
    publisher.put(encode(TeachSwitch(teacher, on)))
    want = keys.teaching(teacher or "*")
    if poll(lambda: any(r.ok is not None for r in session.liveliness().get(want, timeout=1)) == on, 10, 0.02):
        return
    raise TimeoutError(f"teacher {teacher or '(all)'} did not switch {'on' if on else 'off'}")


class BusRecorder:
    """A person's view of a running deployment over the bus: records the loop, switches teachers,
    resets the arena. `certificate`: (a `dogged certs` directory, identity) for a secured router."""

    def __init__(self, endpoint: str, instance: str = "main", robot: str = "aibo",
                 certificate: tuple[Path, str] | None = None):
        self.endpoint = endpoint
        self.keys, self.robot = InstanceKeys(instance), RobotKeys(robot)
        security, identity = certificate or (None, None)
        self.session = zenoh.open(zenoh_config(connect=[endpoint], mode="client", security=security,
                                               identity=identity, give_up_after=30))
        self.recorded: dict[str, list] = {}
        self._held = [self.record(k) for k in (self.keys.input, self.keys.command, self.robot.state,
                                                  f"{self.keys.prefix}/proposal/learner/*")]
        self._teach = lossless_publisher(self.session, self.keys.teach)
        self._arena = lossless_publisher(self.session, self.robot.arena)

    def record(self, key: str):
        """Keep every payload on `key` in self.recorded[key], as (key, bytes, arrival time.time()), while
        the subscriber lives (one subscriber per key)."""
        if key in self.recorded:
            raise ValueError(f"{key} is recorded already")
        bucket = self.recorded[key] = []
        return self.session.declare_subscriber(
            key, lambda s: bucket.append((str(s.key_expr), s.payload.to_bytes(), time.time())))

    def close(self) -> None:
        try:
            for held in self._held:
                held.undeclare()
            self.session.close()
        except zenoh.ZError as err:  # a router gone or out of reach: nothing left to close cleanly
            print(f"closing the session to {self.endpoint}: {err}", file=sys.stderr)

    # --- steering ---------------------------------------------------------------------------
    def teach(self, on: bool, teacher: str = "") -> None:
        switch_teaching(self.session, self._teach, self.keys, on, teacher)

    def reset_arena(self, seed: int, balls: dict) -> None:
        wait_matching(self._arena, 5.0)
        self._arena.put(encode(ArenaReset(seed, balls)))

    def mode(self) -> str:
        """The mode of the newest command: teacher, student, or unsure (the robot asks to be taught)."""
        commands = self.recorded[self.keys.command]
        return decode(Command, commands[-1][1], self.keys.command).mode if commands else ""

    def tick(self) -> int:
        for key, raw, _ in reversed(self.recorded[self.keys.input]):
            msg = decoded(Input, key, raw)
            if msg is not None:
                return msg.tick
        return 0

    def run_ticks(self, count: int, timeout: float = 600.0) -> None:
        target, end = self.tick() + count, time.monotonic() + timeout
        while self.tick() < target:
            if time.monotonic() > end:
                raise TimeoutError(f"the loop stalled at tick {self.tick()} (wanted {target})")
            time.sleep(0.01)

    # --- reading the record -----------------------------------------------------------------
    # (what does not decode is no message: a stranger may have put anything on these keys)
    def inputs(self) -> list[Input]:
        return self.messages(Input, self.keys.input)

    def commands(self) -> list[Command]:
        return self.messages(Command, self.keys.command)

    def learner_proposals(self) -> list[Proposal]:
        return self.messages(Proposal, f"{self.keys.prefix}/proposal/learner/*")

    def states(self, since: int = 0) -> list[RobotState]:
        return self.messages(RobotState, self.robot.state, since)

    def messages(self, cls, key: str, since: int = 0) -> list:
        """The recorded payloads on `key`, from index `since`, that decode as `cls`."""
        return [m for m in (decoded(cls, k, raw) for k, raw, _ in self.recorded[key][since:]) if m is not None]


class LiveRun(BusRecorder):
    """A profile brought up by the supervisor (in a child process), recorded and steered."""

    def __init__(self, profile: Path, run_dir: Path, endpoint: str, instance: str = "main", robot: str = "aibo"):
        self.run_dir = run_dir
        run_dir.mkdir(parents=True, exist_ok=True)
        self._log = open(run_dir / "supervisor.log", "ab")
        self.supervisor = subprocess.Popen([sys.executable, "-m", "services.cli", "up", str(profile), "--router",
                                            endpoint, "--quiet"], cwd=REPO, stdout=self._log,
                                           stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        try:
            wait_announced(profile, endpoint, self.supervisor)
            super().__init__(endpoint, instance, robot)
        except BaseException:  # a supervisor left running would load the machine under every test after
            self.supervisor.terminate()
            self.supervisor.wait(60)
            self._log.close()
            raise

    def ps(self) -> dict:
        out = subprocess.run([sys.executable, "-m", "services.cli", "--connect", self.endpoint, "ps", "--json"],
                             cwd=REPO, capture_output=True, text=True, timeout=30)
        return {r["name"]: r for r in json.loads(out.stdout)["services"]} if out.returncode == 0 else {}

    def wait_ready(self, timeout: float = 180.0) -> None:
        def ready() -> bool:
            if self.supervisor.poll() is not None:
                raise RuntimeError(f"the supervisor exited; see {self.run_dir / 'supervisor.log'}")
            rows = self.ps()
            return bool(rows) and all(r["state"] == "ready" for r in rows.values())
        if poll(ready, timeout, 0.5):
            return
        raise TimeoutError(f"services not ready after {timeout} s: {self.ps()}")

    def close(self) -> int:
        super().close()
        if self.supervisor.poll() is None:  # (a fault suite may have killed it)
            subprocess.run([sys.executable, "-m", "services.cli", "--connect", self.endpoint, "down"], cwd=REPO,
                           capture_output=True, timeout=60)
        try:
            return self.supervisor.wait(60)
        finally:
            self._log.close()


def when_ready(run: LiveRun) -> LiveRun:
    """`run` once every service is ready; if they never are, the whole profile is stopped before the error
    goes up (a supervisor left running would load the machine under every test after)."""
    try:
        run.wait_ready()
        return run
    except BaseException:
        run.close()
        raise
