"""The day carried out on a rig (rigs/soak/day.py's events, at their times), sampled as it goes.

One thread does it all (Playwright's page and the bus's sessions are used from it alone); what takes
seconds runs as a process of its own and is collected when done (`dogged swap`, the stranger's burst), so
the person's hands on the keys and the samples keep their time. Each teacher's switch is held to what the
day last asked: when the arbitrator's status says otherwise a few seconds after (a switch put while the
router was down reaches nobody), it is put again.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from rigs.harness import REPO
from rigs.soak import sample as sampling
from rigs.soak.day import Event, Pace
from rigs.soak.rig import Rig
from rigs.soak.stranger import INSIDE
from rigs.soak.watch import LoopWatch
from bus_schema import router_token
from services.certificates import make_certs
from services.own_identities import home
from services.waiting import poll

SWAP_TRIES, SWAP_AGAIN_S = 3, 5.0  # a swap that failed (the router just killed, say) is asked again
SWITCH_HEARD_S = 2.5  # after a switch, by when the arbitrator's status says who teaches
SWITCH_WINDOW_S = 15.0  # a switch is put again only this soon after it was put (later, keeping it is the system's)
KEPT_CHECK_S = 4.0  # after a killed teacher is back, by when its switch must be as it was
BURST_CASES = 1000
SETTLED_S = 3.0  # after a burst, before the statuses that must show nothing got through are read


@dataclass
class Kill:
    at: float
    service: str
    pid: int
    token: str
    back_at: float | None = None  # its liveliness token declared again
    kept_switch: bool | None = None  # a teacher: back teaching as it was (the supervisor restores the switch)
    new_pid: int | None = None    # `dogged ps` showed it ready with another pid


@dataclass
class Swap:
    at: float
    spec: str
    proc: subprocess.Popen
    tries: int = 1
    end: float | None = None
    ok: bool | None = None
    said: str = ""


@dataclass
class Burst:
    at: float
    proc: subprocess.Popen
    before: dict
    done_at: float | None = None
    result: dict = field(default_factory=dict)


@dataclass
class Row:
    """One sample."""
    t: float                  # seconds since the day began
    procs: dict               # name -> sample.Proc
    tick_ms: tuple            # (p50, p99) of the ticks since the sample before
    answer_ms: tuple          # the learner's answer time, likewise
    error: float | None       # the student's error alone since the sample before (None: it was not alone)
    disk: dict                # MB: recordings, logs, state, and the recordings' filesystem in use
    pairs: dict               # taught, held (status), memory (its model), log (its file), recorded
    page: dict
    restarts: dict


def take_due(queue: list[Event], now: float, held_s: float, swapping: bool) -> tuple[Event | None, float]:
    """The next event of `queue` due at `now` (seconds since the day began) on the day's clock, which is `held_s`
    behind; and held_s. At a `hold` while `swapping` none: the clock stands still there (held_s grows with the
    wait), so every later event moves on by the wait."""
    if not queue or queue[0].at > now - held_s:
        return None, held_s
    if queue[0].kind == "hold" and swapping:
        return None, now - queue[0].at
    return queue.pop(0), held_s


class Driver:
    def __init__(self, rig: Rig, watch: LoopWatch, pace: Pace, log=print):
        self.rig, self.watch, self.pace, self.log = rig, watch, pace, log
        self.t0 = 0.0
        self.rows: list[Row] = []
        self.kills: list[Kill] = []
        self.swaps: list[Swap] = []
        self.swaps_due: list[tuple[str, int, float]] = []  # (spec, try, not before): one at a time, in order
        self.bursts: list[Burst] = []
        self.fills: list[list] = []  # [filled at, freed at, recording again at]
        self.cuts: list[list] = []   # [cut at, healed at]
        self.failed_switches = 0
        self.wanted: dict[str, tuple[bool, float]] = {}  # teacher -> (on, when last switched)
        self._reconciled = 0.0
        self._ps: dict = {}
        self.driving_until = 0.0
        self.held_s = 0.0  # how long the day's clock stood still at its `hold`, for a swap under way
        self._queue: list[Event] = []
        self._marks = {"ticks": 0, "answers": 0, "errors": 0, "at": 0.0}
        self._pair_log = sampling.PairLogCount()
        self.recorded = None  # sample.RecordedSoFar, once the recorder has made its folder
        self.roles = {s.name: s.role for s in rig.profile.services}

    # --- the loop ---------------------------------------------------------------------------------
    def run(self, events: list[Event]) -> None:
        self.t0 = time.time()
        self._queue = sorted(events)
        next_sample, taken = self.pace.sample_s, 0.0
        while True:
            now = time.time() - self.t0
            while True:
                event, self.held_s = take_due(self._queue, now, self.held_s, self.swapping())
                if event is None:
                    break
                self.do(event)
            if now - taken >= 0.25 or now < self.driving_until:
                self.watch.take()
                taken = now
            self.tend(now)
            if now >= next_sample:
                self.sample()
                next_sample += self.pace.sample_s
            if now - self.held_s >= self.pace.length_s and not self._queue and not self.pending():
                break
            time.sleep(0.05)

    def pending(self) -> bool:
        return self.swapping() or any(not b.result for b in self.bursts)

    def swapping(self) -> bool:
        """A swap under way, or due (one that failed, to be asked again)."""
        return bool(self.swaps_due) or any(s.end is None for s in self.swaps)

    def do(self, e: Event) -> None:
        if e.kind == "teach":
            self.switch(*e.arg)
        elif e.kind == "alone":
            self.watch.alone(e.arg[0])
        elif e.kind in ("cut", "heal") and self.rig.lab is not None:
            getattr(self.rig.lab, e.kind)("alice")
            if e.kind == "cut":
                self.cuts.append([time.time(), None])
            elif self.cuts:
                self.cuts[-1][1] = time.time()
        elif e.kind == "drive" and self.rig.person is not None:
            self.driving_until = time.time() - self.t0 + e.arg[0]
        elif e.kind == "swap":
            self.swaps_due.append((e.arg[0], 1, 0.0))
        elif e.kind == "kill":
            self.kill(e.arg[0])
        elif e.kind == "stranger":
            self.stranger()
        elif e.kind == "fill":
            self.fills.append([time.time(), None, None])
            self.log(f"{e.at:7.1f} s: the recordings' disk filled ({self.rig.disk.fill() / 1e6:.0f} MB of ballast)")
        elif e.kind == "free":
            self.rig.disk.free()
            if self.fills:
                self.fills[-1][1] = time.time()
        elif e.kind == "arena":
            self.rig.reset_arena(e.arg[0])
        elif e.kind == "hold" and self.held_s:
            self.log(f"{time.time() - self.t0:7.1f} s: the day waited {self.held_s:.1f} s for the last swap")

    def switch(self, teacher: str, on: bool) -> None:
        self.wanted[teacher] = (on, time.time())
        try:
            self.rig.run.teach(on, teacher)
        except TimeoutError as err:
            self.log(f"{time.time() - self.t0:7.1f} s: {err}")

    def reconcile(self) -> None:
        """Each teacher switched as the day last asked, as the arbitrator says (the other host's while its link
        is cut: it cannot hear the switch, nor the arbitrator its teaching)."""
        cut = bool(self.cuts) and self.cuts[-1][1] is None
        for teacher, (on, at) in list(self.wanted.items()):
            teaching = self.watch.teaching(at + SWITCH_HEARD_S)
            if teaching is None or time.time() - at > SWITCH_WINDOW_S or (cut and teacher == self.rig.teachers[1]) \
                    or (teacher in teaching) == on:
                continue
            self.failed_switches += 1
            self.log(f"{time.time() - self.t0:7.1f} s: {teacher} still {'off' if on else 'on'}: switched again")
            self.switch(teacher, on)

    def tend(self, now: float) -> None:
        """What goes on between events: the person's hands, the teachers' switches, and what the events set
        going."""
        if now - self._reconciled >= 1.0:
            self._reconciled = now
            self.reconcile()
        person = self.rig.person
        if person is not None:
            if now < self.driving_until:
                newest = next(reversed(self.watch._inputs.values()), None)
                person.drive(None if newest is None else newest[0], now)
            elif person.held:
                person.release()
        for kill in self.kills:
            if kill.back_at is None:
                kill.back_at = self.watch.back_at(kill.token, kill.at)
            elif kill.kept_switch is None and kill.service in self.wanted and self.wanted[kill.service][1] < kill.at:
                teaching = self.watch.teaching(kill.back_at + KEPT_CHECK_S)
                if teaching is not None:
                    kill.kept_switch = (kill.service in teaching) == self.wanted[kill.service][0]
        self.tend_swaps()
        for fill in self.fills:  # the recorder recording again: its status without an error, after the free
            if fill[1] is not None and fill[2] is None:
                status = self.watch.taken.statuses.get("recorder/recorder")
                if status and status[1] > fill[1] + 1.0 and not status[0].state.get("error"):
                    fill[2] = status[1]
        for burst in self.bursts:
            self.collect(burst)

    def tend_swaps(self) -> None:
        """The swap under way collected when done (a failed one asked again, first); the next one started."""
        for swap in self.swaps:
            if swap.end is None and swap.proc.poll() is not None:
                swap.end, swap.ok = time.time(), swap.proc.returncode == 0
                swap.said = (swap.proc.stdout.read().strip().splitlines() or [""])[-1][:300]
                self.log(f"{swap.at - self.t0:7.1f} s: swap to {swap.spec}: {'ok' if swap.ok else 'FAILED'}: "
                         f"{swap.said}")
                if not swap.ok and swap.tries < SWAP_TRIES:  # as a person would: again, a little later
                    self.swaps_due.insert(0, (swap.spec, swap.tries + 1, time.time() + SWAP_AGAIN_S))
        if self.swaps_due and self.swaps_due[0][2] <= time.time() and all(s.end is not None for s in self.swaps):
            self.swap(*self.swaps_due.pop(0)[:2])

    # --- events that take a while -----------------------------------------------------------------
    def swap(self, spec: str, tries: int) -> None:
        serving = self.watch.serving_learner()
        command = [sys.executable, "-m", "services.cli", "--connect", self.rig.run.endpoint, "swap", "learner",
                   spec] + (["--service", serving] if serving else [])
        proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                cwd=self.rig.run.run_dir)
        self.swaps.append(Swap(time.time(), spec, proc, tries))

    def kill(self, service: str) -> None:
        name = (self.watch.serving_learner() or "learner") if service == "learner" else service
        row = self.rig.run.ps().get(name, {})
        if not row.get("pid"):
            self.log(f"kill {name}: not running now ({row.get('state', 'unknown')}); skipped")
            return
        token = router_token(self.rig.profile.name) if name == "router" else \
            self.rig.run.keys.alive(self.roles.get(name, "learner"), name)
        os.kill(row["pid"], signal.SIGKILL)
        self.kills.append(Kill(time.time(), name, row["pid"], token))
        self.log(f"{time.time() - self.t0:7.1f} s: SIGKILL {name} (pid {row['pid']})")

    def stranger(self) -> None:
        folder = self.rig.work / "stranger"
        if not (folder / "inside").is_dir():  # this user's CA, after the roster was read: a stranger to it
            make_certs(folder / "inside", [INSIDE], ca_dir=home() / "identities-ca")
        arbitrator = self.watch.status("arbitrator/arbitrator")
        epoch = str(arbitrator.state.get("epoch", "x")) if arbitrator else "x"
        seq = int(arbitrator.state.get("seq", 1)) if arbitrator else 1
        env = {k: v for k, v in os.environ.items() if k not in ("DOGGED_SECURITY", "DOGGED_IDENTITY")}
        env["DOGGED_HOME"] = str(folder / "home")  # none of this user's identities
        proc = subprocess.Popen([sys.executable, "-m", "rigs.soak.stranger", self.rig.endpoint, str(folder),
                                 "--cases", str(BURST_CASES), "--epoch", epoch, "--seq", str(seq),
                                 "--seed", str(len(self.bursts))], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, env=env, cwd=REPO)
        self.bursts.append(Burst(time.time(), proc, self.refusals_now()))

    def refusals_now(self) -> dict:
        rows = self.rig.run.ps()
        return {"refused": sum(sum(r.get("refused", {}).values()) for r in rows.values()),
                "rejected": sum(self.watch.rejected().values())}

    def collect(self, burst: Burst) -> None:
        if burst.result:
            return
        if burst.done_at is None:
            if burst.proc.poll() is None:
                return
            burst.done_at = time.time()
        if time.time() < burst.done_at + SETTLED_S:
            return
        out, err = burst.proc.communicate()
        try:
            ways = json.loads(out.strip().splitlines()[-1])
        except (IndexError, json.JSONDecodeError):
            ways = {"error": (err or out)[-300:]}
        after = self.refusals_now()
        burst.result = {"ways": ways, "refused": after["refused"] - burst.before["refused"],
                        "got_through": after["rejected"] - burst.before["rejected"]}
        self.log(f"{burst.at - self.t0:7.1f} s: a stranger's burst: {burst.result}")

    # --- sampling ---------------------------------------------------------------------------------
    def sample(self) -> Row:
        taken = self.watch.take()
        rows = self.rig.run.ps() or self._ps  # (none while the router is down: those of the sample before)
        self._ps = rows
        pids = sampling.service_pids(self.rig.run.supervisor.pid)
        pids.update(supervisor=self.rig.run.supervisor.pid, page=sampling.page_pid(),
                    remote=self.rig.remote.pid if self.rig.remote is not None else None)
        m = self._marks
        ticks = np.array([dt for _, dt, _ in taken.ticks[m["ticks"]:]]) * 1e3
        answers = np.array([dt for _, dt in taken.answers[m["answers"]:]]) * 1e3
        errors = [e for _, _, e, _ in taken.errors[m["errors"]:]]
        m.update(ticks=len(taken.ticks), answers=len(taken.answers), errors=len(taken.errors))
        row = Row(round(time.time() - self.t0, 1), sampling.procs(pids), percentiles(ticks), percentiles(answers),
                  float(np.mean(errors)) if errors else None, self.disk(), self.pairs(), self.rig.page_state(),
                  {n: r.get("restarts", 0) for n, r in rows.items() if r.get("state") != "remote"})
        self.rows.append(row)
        for kill in self.kills:
            now = rows.get(kill.service, {})
            if kill.new_pid is None and now.get("pid") and now["pid"] != kill.pid and now.get("state") == "ready":
                kill.new_pid = now["pid"]
        return row

    def disk(self) -> dict:
        run_dir, folder = self.rig.work, self.rig.disk.folder
        return {"recordings": round(sampling.folder_mb(folder / "recordings"), 2),
                "logs": round(sampling.folder_mb(self.rig.profile.log_dir), 2),
                "state": round(sampling.folder_mb(self.rig.state_dir()), 2),
                "filesystem": round(sampling.disk_used_mb(folder), 2) if folder.is_dir() else 0.0,
                "work": round(sampling.folder_mb(run_dir) - sampling.folder_mb(folder), 2)}

    def pairs(self) -> dict:
        serving = self.watch.serving_learner()
        member = f"learner/{serving}"
        if self.recorded is None and self.rig.recordings() is not None:
            self.recorded = sampling.RecordedSoFar(self.rig.recordings(), self.rig.run.keys)
        if self.recorded is not None:
            self.recorded.update()
        return {"taught": self.watch.taught(), "held": self.watch.counter(member, "pairs"),
                "memory": self.watch.taken.learned.get(serving, 0),
                "log": self._pair_log(self.rig.state_dir() / f"{serving}.pairs") if serving else 0,
                "recorded": len(self.recorded.pairs()) if self.recorded is not None else 0,
                "lost_by_learner": self.watch.counter(member, "pairs_lost"), "learner": serving}

    # --- the end ----------------------------------------------------------------------------------
    def finish(self, timeout: float = 60.0) -> Row:
        """Every teacher off, the learner caught up with every pair taught; the last sample."""
        try:
            self.rig.run.teach(False)
        except TimeoutError as err:
            self.log(f"the end: {err}")

        def caught_up() -> bool:
            self.watch.take()
            serving = self.watch.serving_learner()
            return bool(serving) and self.watch.counter(f"learner/{serving}", "pairs") >= self.watch.taught()
        if poll(caught_up, timeout, 1.0):
            time.sleep(1.5)  # one more status of each, after the last pair
        return self.sample()


def percentiles(ms: np.ndarray) -> tuple:
    return (round(float(np.percentile(ms, 50)), 3), round(float(np.percentile(ms, 99)), 3)) if len(ms) else (None, None)
