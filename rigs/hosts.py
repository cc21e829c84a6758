"""Mirroring spread over four machines, as the mission draws it (issue 13): hosts are network
namespaces on one switch (rigs/netlab/lab.py), every link mutual TLS with access control.

- robot: the router, the Aibo at 30 Hz in real time, the handler (`dogged up robot.toml`);
- brain: the learner and the arbitrator (`dogged up brain.toml --join <robot's router>`), peers of
  the brain's own router, which links to the robot's;
- alice, bob: one teacher each, joined with one command (`dogged run demonstrator ... --connect
  <robot's router> --security <certs> --identity teacher.<name>`), switched by their person with
  `dogged teach` from their own host.

This process watches from the switch (operator.lab): it records the loop and the arbitrator's
status, which it publishes at once when it stops or starts waiting for someone. With `radio`, the
robot's cable runs through rigs/netlab/air.py, which drops and delays frames.
"""
from __future__ import annotations

import bisect
import json
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bus_schema import Command, Input, Status
from rigs.harness import REPO
from rigs.live.mirroring import param_args
from rigs.netlab.lab import Lab
from services.demo.live import BusRecorder, decoded
from services.experiments.wiring import wired_learner
from services.waiting import poll

ROBOT, BRAIN = "robot", "brain"
TEACHERS = {"alice": ("pan", "pan"), "bob": ("tilt", "tilt")}  # host -> (teacher service, axes)
PY = sys.executable
BRAIN_LINK = "quic"  # how the brain joins the robot's router: see benchmarks/hosts.py
LOSSY_DEADLINE_MS = 60.0  # the arbitrator's wait for proposals over the radio (three crossings)


@dataclass(frozen=True)
class Link:
    """How the brain reaches the robot's router: a Zenoh link scheme, and the radio's impairment."""
    scheme: str = BRAIN_LINK     # tls (TCP) or quic (UDP)
    loss: float = 0.0            # share of frames dropped, each way
    jitter_ms: float = 0.0       # each frame delayed uniform 0..jitter_ms

    @property
    def radio(self) -> bool:
        return self.loss > 0 or self.jitter_ms > 0


def robot_profile(run_dir: Path, certs: Path, router: str, rate: float, listen_also: list[str]) -> str:
    return f"""[profile]
name = "robot"
log_dir = "{run_dir}/robot/logs"
state_dir = ""

[zenoh]
router = "{router}"
also_listen = {json.dumps(listen_also)}
security = "{certs}"

[services.aibo]
box = "aibo"
args = ["--command", "joints", "--input", "joints", "--rate", "{rate}", "--camera-hz", "0"]

[services.handler]
box = "handler"
args = ["--distractors", "mirroring"]
"""


def brain_profile(run_dir: Path, certs: Path, deadline_ms: float) -> str:
    learner, params = wired_learner("mirroring")
    return f"""[profile]
name = "brain"
log_dir = "{run_dir}/brain/logs"
state_dir = ""

[zenoh]
router = "tls/127.0.0.1:7447"
security = "{certs}"

[services.learner]
box = "learner"
args = ["--learner", "{learner}"{param_args(params)}]

[services.arbitrator]
box = "arbitrator"
args = ["--deadline-ms", "{deadline_ms}"]
"""


class Hosts:
    def __init__(self, run_dir: Path, link: Link = Link(), rate: float = 30.0, deadline_ms: float = 20.0,
                 net: int | None = None, colocated: bool = False):
        """`colocated`: every process on the robot host instead (the baseline: the same deployment,
        no network crossed)."""
        self.run_dir, self.link, self.rate, self.deadline_ms = Path(run_dir), link, rate, deadline_ms
        self.lab = Lab([ROBOT, BRAIN, *TEACHERS], radio=ROBOT if link.radio else None, net=net,
                       workdir=str(self.run_dir / "lab"), observer=True)
        self.colocated = colocated
        self.certs = self.run_dir / "certs"
        self.router = f"tls/{self.lab.address[ROBOT]}:7447"
        self.brain_router = f"{link.scheme}/{self.lab.address[ROBOT]}:7447"
        self.bus: BusRecorder | None = None
        self.teachers: dict[str, subprocess.Popen] = {}

    # --- bringing it up ------------------------------------------------------------------------
    def __enter__(self) -> Hosts:
        (self.run_dir / "lab").mkdir(parents=True, exist_ok=True)
        self.lab.__enter__()
        try:
            if self.link.radio:
                self.lab.impair(ROBOT, loss=self.link.loss, jitter_ms=self.link.jitter_ms)
            self._start()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _start(self) -> None:
        robot, brain = self.run_dir / "robot.toml", self.run_dir / "brain.toml"
        also = [self.brain_router] if self.brain_router != self.router else []
        robot.write_text(robot_profile(self.run_dir, self.certs, self.router, self.rate, also))
        brain.write_text(brain_profile(self.run_dir, self.certs, self.deadline_ms))
        people = [f"teacher.{t}" for t, _ in TEACHERS.values()] + [f"operator.{h}" for h in TEACHERS] + ["operator.lab"]
        made = self.dogged(None, "certs", str(self.certs), "--profile", str(robot), "--profile", str(brain),
                           *sum((["--identity", p] for p in people), []))
        if made.returncode != 0:
            raise RuntimeError(f"dogged certs: {made.stderr}")
        self.lab.run(ROBOT, [PY, "-m", "services.cli", "up", str(robot), "--quiet"], log=self.run_dir / "robot.log",
                     cwd=REPO)
        self.lab.run(self.on(BRAIN), [PY, "-m", "services.cli", "up", str(brain), "--join", self.brain_router,
                                      "--quiet"],
                     log=self.run_dir / "brain.log", cwd=REPO)
        for host in TEACHERS:
            self.start_teacher(host)
        self.bus = BusRecorder(self.router, certificate=(self.certs, "operator.lab"))
        self.status_key = self.bus.keys.status("arbitrator", "arbitrator")
        self.aibo_status_key = self.bus.keys.status("aibo", "aibo")
        self._held = [self.bus.record(k) for k in (self.status_key, self.aibo_status_key)]

    def start_teacher(self, host: str) -> subprocess.Popen:
        name, axes = TEACHERS[host]
        self.teachers[host] = self.lab.run(self.on(host), [
            PY, "-m", "services.cli", "run", "demonstrator", "--instance", "main", "--name", name, "--teacher",
                                                           "mirror",
            "--param", f"axes={axes}", "--connect", self.router, "--security", str(self.certs),
            "--identity", f"teacher.{name}"], log=self.run_dir / f"{host}.log", cwd=REPO)
        return self.teachers[host]

    def close(self) -> None:
        if self.bus is not None:
            self.bus.close()
            self.bus = None
        for host, profile in ((BRAIN, "brain"), (ROBOT, "robot")):
            try:  # a clean stop first, so services end their sessions; the lab kills what is left
                self.dogged(host, "--profile", profile, "down", identity="operator.lab", timeout=40)
            except (subprocess.TimeoutExpired, OSError):
                pass
        self.lab.close()

    def on(self, host: str) -> str:
        """The namespace that plays `host`."""
        return ROBOT if self.colocated else host

    # --- a person on a host --------------------------------------------------------------------
    def dogged(self, host: str | None, *args: str, identity: str | None = None,
               timeout: float = 60) -> subprocess.CompletedProcess:
        """`dogged <args>` as run on `host` (None: here, no bus), with `identity`'s certificate."""
        command = [PY, "-m", "services.cli"]
        if identity:
            command += ["--connect", self.router, "--security", str(self.certs), "--identity", identity]
        if host is None:
            return subprocess.run(command + list(args), cwd=REPO, capture_output=True, text=True, timeout=timeout)
        return subprocess.run(self.lab.command(self.on(host), command + list(args)), cwd=REPO, capture_output=True,
                              text=True,
                              timeout=timeout)

    def teach(self, host: str, on: bool) -> subprocess.CompletedProcess:
        """The person at `host` switches their teacher, from there."""
        name, _ = TEACHERS[host]
        return self.dogged(host, "teach", "on" if on else "off", "--teacher", name, identity=f"operator.{host}")

    def wait_ready(self, timeout: float = 180.0) -> None:
        """Every service of both profiles ready, and commands flowing to this observer."""
        def ready() -> bool:
            for host, proc in self.teachers.items():
                if proc.poll() is not None:
                    raise RuntimeError(f"the teacher on {host} exited; see {self.run_dir / (host + '.log')}")
            names = {r["name"]: r for r in self.ps(ROBOT)}
            want = {"aibo", "handler", "learner", "arbitrator", "pan", "tilt"}
            return want <= names.keys() and all(names[n]["state"] in ("ready", "remote") for n in want) \
                and bool(self.commands_since(time.time() - 1.0))
        if poll(ready, timeout, 0.5):
            return
        raise TimeoutError(f"not ready after {timeout} s: {self.ps(ROBOT)}")

    def ps(self, host: str, profile: str = "robot") -> list[dict]:
        out = self.dogged(host, "--profile", profile, "ps", "--json", identity="operator.lab", timeout=30)
        return json.loads(out.stdout)["services"] if out.returncode == 0 else []

    # --- reading the record --------------------------------------------------------------------
    # (records are in arrival order; what does not decode is no message)
    def received(self, key: str, cls, after: float) -> list[tuple[float, object]]:
        """(arrival time.time(), message) of every `cls` on `key` that reached this observer after `after`."""
        records = self.bus.recorded[key]
        first = bisect.bisect_right(records, after, key=lambda record: record[2])
        return [(at, m) for k, raw, at in records[first:] for m in [decoded(cls, k, raw)] if m is not None]

    def first_received(self, key: str, cls, after: float, timeout: float, wanted=lambda msg: True):
        """The first (arrival, message) of `cls` on `key` after time.time() `after` that is `wanted`,
        waiting until `timeout` s past `after` (or past now); None if none came."""
        records = self.bus.recorded[key]
        i = bisect.bisect_right(records, after, key=lambda record: record[2])
        end = time.monotonic() + max(0.0, after - time.time()) + timeout
        while True:
            for k, raw, at in records[i:]:  # only what came since the last look (`after` may be ahead)
                i += 1
                msg = decoded(cls, k, raw) if at > after else None
                if msg is not None and wanted(msg):
                    return at, msg
            if time.monotonic() >= end:
                return None
            time.sleep(0.02)

    def commands_since(self, t: float) -> list:
        """(arrival time, Command) of every command that reached this observer after time.time() `t`."""
        return self.received(self.bus.keys.command, Command, t)

    def waited_for_change(self, member: str, waited: bool, since: float, timeout: float) -> float | None:
        """Seconds from `since` until the arbitrator said it (stopped) waiting for `member` (teacher/pan)."""
        found = self.first_received(self.status_key, Status, since, timeout,
                                    lambda s: (member not in s.state.get("not_waited_for", [])) == waited)
        return None if found is None else found[0] - since

    def first_command_from(self, source: str, since: float, timeout: float) -> float | None:
        """Seconds from `since` until a command chosen from `source` (teacher/pan; "": any) reached
        this observer."""
        found = self.first_received(self.bus.keys.command, Command, since, timeout,
                                    lambda c: not source or c.source == source)
        return None if found is None else found[0] - since


# --- the scenarios, shared by tests/test_hosts.py and benchmarks/hosts.py ---------------
@dataclass
class Partition:
    detect_s: float | None      # cut -> the arbitrator said it stopped waiting for the teacher
    heal_s: float | None        # heal -> the first command chosen from that teacher
    commands_while_cut: int     # commands that reached the robot's router while the teacher was away
    modes_while_cut: set
    restarted: bool             # the teacher's process had to start again (it must not)


def teacher_partition(hosts: Hosts, host: str = "alice", cut_s: float = 3.0) -> Partition:
    """The person at `host` teaches; their link is cut for `cut_s`, then restored."""
    name, _ = TEACHERS[host]
    member, process = f"teacher/{name}", hosts.teachers[host]
    if hosts.teach(host, True).returncode != 0:
        raise RuntimeError(f"dogged teach on, on {host}, failed")
    if hosts.first_command_from(member, time.time(), 10) is None:
        raise RuntimeError(f"{member} never drove the robot")
    cut = time.time()
    hosts.lab.cut(host)
    detect = hosts.waited_for_change(member, False, cut, timeout=5)
    time.sleep(max(0.0, cut + cut_s - time.time()))
    during = [c for at, c in hosts.commands_since(cut + 1.0)]
    healed = time.time()
    hosts.lab.heal(host)
    heal = hosts.first_command_from(member, healed, timeout=30)
    hosts.teach(host, False)
    return Partition(detect, heal, len(during), {c.mode for c in during}, process.poll() is not None)


@dataclass
class BrainPartition:
    held_before: int
    held_after: int             # the robot's watchdog count at the end of the cut
    head_motion_rad: float      # how far the head moved while held (from 1 s after the cut)
    commands_while_cut: int
    resume_s: float | None      # heal -> the first command at the robot's router


def brain_partition(hosts: Hosts, cut_s: float = 3.0) -> BrainPartition:
    """The brain (learner, arbitrator) loses the robot for `cut_s`: the robot must hold still."""
    from services.platforms.aibo.joints import HEAD_PAN, HEAD_TILT
    held_before = _latest_counter(hosts, hosts.aibo_status_key, "held")
    cut = time.time()
    hosts.lab.cut(BRAIN)
    time.sleep(cut_s)
    commands = [c for at, c in hosts.commands_since(cut + 1.0)]
    inputs = hosts.received(hosts.bus.keys.input, Input, cut + 1.0)
    head = np.array([m.x[[HEAD_PAN, HEAD_TILT]] for _, m in inputs]) if inputs else np.zeros((1, 2))
    time.sleep(1.2)  # the platform says its status each second
    held_after = _latest_counter(hosts, hosts.aibo_status_key, "held")
    healed = time.time()
    hosts.lab.heal(BRAIN)
    resume = hosts.first_command_from("", healed, timeout=30)
    return BrainPartition(held_before, held_after, float(np.ptp(head, axis=0).max()), len(commands), resume)


def _latest_counter(hosts: Hosts, key: str, counter: str) -> int:
    for k, raw, _ in reversed(hosts.bus.recorded[key]):
        status = decoded(Status, k, raw)
        if status is not None:
            return int(status.counters.get(counter, 0))
    return 0


@dataclass
class Lesson:
    taught_s: float             # seconds of ticks the teachers drove before the student was right
    error_rad: float            # the student's RMS head error over the last evaluation
    learned: bool
    rounds: list                # (taught_s, error_rad) after each round


def teach_until_learned(hosts: Hosts, step_s: float = 1.0, judge_s: float = 3.0, max_taught_s: float = 10.0,
                        bound: float = 0.05) -> Lesson:
    """Both teachers on for `step_s` at a time (switched from the lab), then the student alone for
    `judge_s`, judged on the head axes against the mirroring teacher, until its RMS is under `bound`."""
    from rigs.live.mirroring import student_error
    bus, rounds, taught = hosts.bus, [], 0.0
    while taught < max_taught_s:
        started = time.time()
        bus.teach(True)
        time.sleep(step_s)
        bus.teach(False)
        taught += sum(1 for _, c in hosts.commands_since(started) if c.mode == "teacher") / hosts.rate
        time.sleep(0.5)  # the last lesson reaches the learner
        since = bus.tick()
        time.sleep(judge_s)
        error, _ = student_error(bus, since)
        rounds.append((round(taught, 2), round(error, 4)))
        if error < bound:
            return Lesson(taught, error, True, rounds)
    return Lesson(taught, rounds[-1][1] if rounds else float("inf"), False, rounds)


@dataclass
class Window:
    ticks: int
    lost: int                   # ticks no command answered (within the platform's answer window)
    stale: int                  # commands that came after the next tick had gone out
    latency_p50_ms: float       # tick -> command at the robot: median over 10-s spans
    latency_p99_ms: float       # the worst 10-s span's 99th percentile

    @property
    def lost_share(self) -> float:
        return self.lost / max(self.ticks, 1)

    @property
    def stale_share(self) -> float:
        return self.stale / max(self.ticks, 1)


def loop_window(hosts: Hosts, spans: int = 1) -> Window:
    """The loop as the robot saw it for `spans` x 10 s (its status: counters, and latency percentiles
    over its last 10 s)."""
    from services.boxes.platform import LATENCY_WINDOW_S
    first = _newest_status(hosts, hosts.aibo_status_key, time.time())
    p50s, p99s, last = [], [], first
    for _ in range(spans):
        last = _newest_status(hosts, hosts.aibo_status_key, time.time() + LATENCY_WINDOW_S)
        p50s.append(last.state["latency_p50_ms"])
        p99s.append(last.state["latency_p99_ms"])

    def delta(counter):
        return int(last.counters.get(counter, 0)) - int(first.counters.get(counter, 0))
    return Window(delta("tick"), delta("lost_ticks"), delta("stale_commands"), float(np.median(p50s)), max(p99s))


def _newest_status(hosts: Hosts, key: str, after: float, timeout: float = 15.0) -> Status:
    """The first status on `key` that arrives after time.time() `after`."""
    found = hosts.first_received(key, Status, after, timeout)
    if found is None:
        raise TimeoutError(f"no status on {key} after {after}")
    return found[1]
