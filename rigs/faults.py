"""Faults over a running deployment, measured as the robot's user would feel them (issue 12).

A mirroring deployment runs in real time at 30 Hz under the supervisor, every service restarted
by policy, the learner keeping its state (`--state-dir`), a teacher teaching; optionally first a
ball-seeking one (camera at 15 Hz), whose perception is killed. Each fault SIGKILLs
one service (or SIGSTOPs it for a while) and measures, from the bus:

- recovery: from the fault until commands flow again (the end of the longest gap in commands that
  began after the fault; 0 if the commands never stopped);
- ticks lost: control periods (1/30 s) inside that gap without a command;
- pairs lost: training pairs the arbitrators published that the learner does not hold once it has
  caught up (the learner's `pairs` counter against every epoch's last seq), and the learner's own
  `pairs_lost` count.

Supervisor death is last: every service must be gone within a few seconds (no orphans).
"""
from __future__ import annotations

import json
import os
import signal
import time
from dataclasses import dataclass
from pathlib import Path

from bus_schema import SchemaError, Status, TrainingPair, decode
from services.demo.live import LiveRun
from services.waiting import poll

RATE = 30.0
GAP = 0.25  # seconds without a command that count as commands having stopped (7.5 periods)


def profile_text(name: str, run_dir: Path, services: dict[str, tuple[str, list[str]]], security: str = "") -> str:
    """A profile whose every service (name: (box, args)) is restarted whenever it dies; `security` its
    zenoh.security (default: this user's own identities)."""
    tables = "".join(f'\n[services.{service}]\nbox = "{box}"\nargs = {json.dumps(args)}\nrestart = "always"\n'
                     for service, (box, args) in services.items())
    zenoh = f'\n[zenoh]\nsecurity = "{security}"\n' if security else ""
    return f'[profile]\nname = "{name}"\nlog_dir = "{run_dir}/logs"\n{tables}{zenoh}'


def learner_args(run_dir: Path, learner: str) -> list[str]:
    return ["--learner", learner, "--state-dir", f"{run_dir}/state"]


def mirroring_profile(run_dir: Path, learner: str, rate: float = RATE, security: str = "") -> str:
    return profile_text("faults", run_dir, {
        "aibo": ("aibo", ["--command", "joints", "--input", "joints", "--rate", str(rate), "--camera-hz", "0"]),
        "handler": ("handler", ["--distractors", "mirroring"]),
        "mirror": ("demonstrator", ["--teacher", "mirror"]),
        "learner": ("learner", learner_args(run_dir, learner)),
        "arbitrator": ("arbitrator", []),
    }, security)


KILLED = ("learner", "arbitrator", "aibo", "mirror", "handler", "router")
STOPPED = {"mirror": 5.0}  # SIGSTOP for this long, then SIGCONT: a frozen teacher
# ball seeking, for the one service mirroring lacks: perception, between the camera and the loop
CAMERA_RATE = 15.0


def camera_profile(run_dir: Path, learner: str, rate: float = CAMERA_RATE) -> str:
    return profile_text("faults-camera", run_dir, {
        "aibo": ("aibo", ["--command", "move", "--input", "camera", "--rate", str(rate)]),
        "perception": ("perception", ["--layout", "slots"]),
        "seeker": ("demonstrator", ["--teacher", "ballseek"]),
        "learner": ("learner", learner_args(run_dir, learner)),
        "arbitrator": ("arbitrator", []),
    })


CAMERA_KILLED = ("perception",)


@dataclass
class FaultResult:
    fault: str
    recovery_s: float
    ticks_lost: int
    pairs_lost: int
    restarted: bool
    teacher_kept_teaching: bool  # the person's switch survived the fault


SETTLE_S = 0.5  # after teaching paused, for the last pairs to reach the learner


class BusRecord:
    """Arrival times of commands, every training pair seen, the newest status of each service."""

    def __init__(self, run: LiveRun):
        keys = run.keys
        self.command_times: list[float] = []
        self.pair_seqs: dict[str, int] = {}  # epoch -> highest seq published
        self.statuses: dict[str, Status] = {}
        self.status_arrived: dict[str, float] = {}  # name -> when its newest status came (monotonic)
        session = run.session
        self._held = [session.declare_subscriber(keys.command, self._on_command),
                      session.declare_subscriber(keys.train, self._on_pair),
                      session.declare_subscriber(f"{keys.prefix}/status/**", self._on_status)]

    def _on_command(self, sample) -> None:
        self.command_times.append(time.monotonic())

    def _on_pair(self, sample) -> None:
        try:
            pair = decode(TrainingPair, sample.payload.to_bytes(), str(sample.key_expr))
        except SchemaError:  # a record, not a service: what does not decode is not counted
            return
        self.pair_seqs[pair.epoch] = max(pair.seq, self.pair_seqs.get(pair.epoch, 0))

    def _on_status(self, sample) -> None:
        try:
            status = decode(Status, sample.payload.to_bytes(), str(sample.key_expr))
        except SchemaError:
            return
        self.statuses[status.name] = status
        self.status_arrived[status.name] = time.monotonic()
        if status.role == "arbitrator":
            epoch, seq = status.state.get("epoch"), status.state.get("seq")
            if isinstance(epoch, str) and isinstance(seq, int):
                self.pair_seqs[epoch] = max(seq, self.pair_seqs.get(epoch, 0))

    def published(self) -> int:
        return sum(self.pair_seqs.values())

    def learner_pairs(self) -> tuple[int, int]:
        """(pairs the learner holds, pairs it counted lost), from its newest status."""
        status = self.statuses.get("learner")
        if status is None:
            return 0, 0
        return int(status.counters.get("pairs", 0)), int(status.counters.get("pairs_lost", 0))

    def gap_after(self, start: float) -> float:
        """The longest gap between commands that ended after `start` (counted from `start` at most)."""
        times = [t for t in self.command_times if t >= start - 1.0]
        return max((after - max(before, start) for before, after in zip(times, times[1:]) if after > start),
                   default=0.0)

    def flowing(self, since: float) -> bool:
        """Whether commands flow (one in the last GAP / 2) at least 2 * GAP after `since` (a gap they began
        after a fault has shown by then)."""
        now = time.monotonic()
        return now - since >= 2 * GAP and bool(self.command_times) and now - self.command_times[-1] < GAP / 2

    def close(self) -> None:
        for held in self._held:
            held.undeclare()


def wait_restarted(run: LiveRun, service: str, timeout: float = 20.0) -> bool:
    """The service back (restarted, or continued after SIGSTOP) and every service ready."""
    def back() -> bool:
        rows = run.ps()
        ready = bool(rows) and all(r["state"] == "ready" for r in rows.values())
        return ready and bool(rows.get(service, {}).get("pid"))
    return bool(poll(back, timeout, 0.25))


def pair_deficit(run: LiveRun, record: BusRecord) -> tuple[int, int]:
    """With teaching paused: (pairs published that the learner does not hold, its pairs_lost count), once the
    learner and the arbitrator have each said so in a status composed SETTLE_S after the last pair (once a second
    each: where it waited a fixed 2.5 s, now 0.5-1.5)."""
    run.teach(False)
    paused = time.monotonic()
    poll(lambda: all(record.status_arrived.get(name, 0.0) >= paused + SETTLE_S for name in ("learner", "arbitrator")),
         10.0, 0.05)
    held, lost = record.learner_pairs()
    return record.published() - held, lost


def teaching(run: LiveRun, teacher: str) -> bool:
    want = f"{run.keys.prefix}/alive/teaching/{teacher}"
    return any(r.ok is not None for r in run.session.liveliness().get(want, timeout=1))


def strike(run: LiveRun, record: BusRecord, service: str, how: str, deficit: tuple[int, int],
           log=print, teacher: str = "mirror", rate: float = RATE) -> tuple[FaultResult, tuple[int, int]]:
    pid = run.ps()[service]["pid"]
    start = time.monotonic()
    if how == "stop":
        os.kill(pid, signal.SIGSTOP)
        time.sleep(STOPPED[service])
        os.kill(pid, signal.SIGCONT)
    else:
        os.kill(pid, signal.SIGKILL)
    # first the commands, from the bus record in this process; only then `dogged ps`, whose processes (half a
    # second of CPU each, four a second) would otherwise slow the very restart being measured
    poll(lambda: record.flowing(start), 20.0, 0.02)
    back = wait_restarted(run, service)
    time.sleep(1.5)  # steady flow after
    still_teaching = teaching(run, teacher)
    gap = record.gap_after(start)
    recovery = gap if gap > GAP else 0.0
    after = pair_deficit(run, record)
    pairs_lost = max(0, after[0] - deficit[0]) + max(0, after[1] - deficit[1])
    result = FaultResult(f"{how} {service}", round(recovery, 3), int(recovery * rate), pairs_lost, back,
                         still_teaching)
    log(f"{result.fault}: commands again after {result.recovery_s:.2f} s, {result.ticks_lost} ticks and "
        f"{result.pairs_lost} pairs lost; back: {back}; the teacher still teaching: {still_teaching}")
    run.teach(True)  # as the person would, whatever the fault left
    time.sleep(1.0)
    return result, after


def children_gone(pids: list[int], timeout: float = 10.0) -> bool:
    return bool(poll(lambda: not any(_alive(pid) for pid in pids), timeout, 0.2))


def _alive(pid: int) -> bool:
    """Whether the process runs (a zombie, dead but not yet reaped, does not)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(") ")[-1].split()[0]
    except OSError:
        return False
    return state != "Z"


def strike_in_turn(run: LiveRun, record: BusRecord, plan, warm: float, log, teacher: str, rate: float) -> list:
    """Teach, then each (how, service) of `plan` in turn; the last pair deficit ends the list's run."""
    run.wait_ready()
    run.teach(True)
    time.sleep(warm)
    deficit = pair_deficit(run, record)
    run.teach(True)
    results = []
    for how, service in plan:
        result, deficit = strike(run, record, service, how, deficit, log, teacher, rate)
        results.append(result)
    return results


def run_faults(run_dir: Path, endpoint: str, learner: str = "lwpr", killed=KILLED, stopped=tuple(STOPPED),
               warm: float = 3.0, log=print, camera_endpoint: str | None = None, camera_killed=CAMERA_KILLED) -> dict:
    """Start the deployment, teach, strike each fault in turn, then kill the supervisor. With a
    `camera_endpoint`, first the ball-seeking deployment on it, for perception's faults."""
    run_dir.mkdir(parents=True, exist_ok=True)
    out = {"results": [], "published": 0, "learner_pairs": 0, "learner_pairs_lost": 0, "pairs_missing": 0,
           "orphans_gone": False}

    def deploy(name: str, profile, at: str) -> tuple[LiveRun, BusRecord]:
        folder = run_dir / name
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "faults.toml").write_text(profile(folder, learner))
        run = LiveRun(folder / "faults.toml", folder, at)
        return run, BusRecord(run)

    def tally(run: LiveRun, record: BusRecord) -> None:
        final = pair_deficit(run, record)
        held, lost = record.learner_pairs()
        out["published"] += record.published()
        out["learner_pairs"] += held
        out["learner_pairs_lost"] += lost
        out["pairs_missing"] += final[0]

    if camera_endpoint and camera_killed:
        run, record = deploy("camera", camera_profile, camera_endpoint)
        try:
            out["results"] += strike_in_turn(run, record, [("kill", s) for s in camera_killed], warm, log, "seeker",
                                             CAMERA_RATE)
            tally(run, record)
        finally:
            record.close()
            run.close()
    run, record = deploy("mirroring", mirroring_profile, endpoint)
    try:
        plan = [("stop", s) for s in stopped] + [("kill", s) for s in killed]
        out["results"] += strike_in_turn(run, record, plan, warm, log, "mirror", RATE)
        tally(run, record)
        pids = [r["pid"] for r in run.ps().values() if r.get("pid")]
        run.supervisor.send_signal(signal.SIGKILL)
        out["orphans_gone"] = children_gone(pids)
        log(f"kill supervisor: every service gone: {out['orphans_gone']}")
    finally:
        record.close()
        run.close()
    return out
