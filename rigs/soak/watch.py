"""What the loop did, from a LiveRun's record of the bus, taken in as it comes (an hour of it would not fit
in a list): each tick's time (its command's arrival here less its input's stamp), the learner's answer time
(its proposal's arrival less its input's), the student's error while alone (the teacher's program run on the
same input: the paper's measure), the pairs the arbitrators numbered, every service's newest status, and
liveliness tokens coming and going (a killed service is back when its token is)."""
from __future__ import annotations

import collections
import threading
import time
from dataclasses import dataclass, field

import numpy as np
import zenoh

from bus_schema import Command, Input, Proposal, Status, TrainingPair, decoded
from services.experiments.evaluate import error_over_time

KEEP = 8  # the newest payloads left in the LiveRun's lists: its own tick() and mode() read them
RECENT_INPUTS = 4096  # inputs kept for their commands and proposals to find (minutes of ticks)


@dataclass
class Judge:
    """The student's error on a tick: the teacher's program on its input, against the command, RMS over
    `outputs` of the difference over `scale` (half each output's range)."""
    teacher: object
    outputs: list[int]
    scale: np.ndarray

    def __call__(self, x: np.ndarray, y: np.ndarray) -> float | None:
        wanted, _ = self.teacher(x)
        if wanted is None:
            return None
        return float(error_over_time(np.asarray(wanted)[None], np.asarray(y)[None], self.outputs, self.scale)[0])


@dataclass
class Taken:
    """Everything the watch has taken in since the start (times are time.time())."""
    ticks: list = field(default_factory=list)      # (command arrival, tick seconds, mode)
    answers: list = field(default_factory=list)    # (proposal arrival, seconds since its input arrived)
    errors: list = field(default_factory=list)     # (command arrival, alone span index, error, the learner's answer)
    judged: tuple = (None, [])                     # (the newest span judged, the inputs judged in it)
    inputs: list = field(default_factory=list)     # (input stamp, arrival): what the run published
    epochs: dict = field(default_factory=dict)     # arbitrator epoch -> the highest seq numbered in it
    learned: dict = field(default_factory=dict)    # learner name -> pairs its model holds (newest proposal)
    statuses: dict = field(default_factory=dict)   # role/name -> (newest Status, arrival)
    tokens: list = field(default_factory=list)     # (key, "PUT" | "DELETE", arrival)


class LoopWatch:
    def __init__(self, run, judge: Judge, profile_name: str):
        self.run, self.judge, self.keys = run, judge, run.keys
        self.taken = Taken()
        self.status_key = f"{self.keys.prefix}/status/**"
        self._held = [run.record(self.keys.train), run.record(self.status_key)]
        self._tokens: list = []
        self._lock = threading.Lock()
        liveliness = run.session.liveliness()
        self._held += [liveliness.declare_subscriber(key, self._on_token)
                       for key in (f"{self.keys.prefix}/alive/**", f"dogged/router/{profile_name}")]
        self._seen = collections.Counter()  # per recorded key: payloads at the head of its list already taken
        self._inputs: collections.OrderedDict = collections.OrderedDict()  # tick -> (x, stamp, arrival)
        self.alone_spans: list[list] = []  # [start, end or None]

    def _on_token(self, sample) -> None:  # Zenoh's thread: only appends
        with self._lock:
            kind = "PUT" if sample.kind == zenoh.SampleKind.PUT else "DELETE"
            self._tokens.append((str(sample.key_expr), kind, time.time()))

    # --- the driver's marks -----------------------------------------------------------------------
    def alone(self, on: bool) -> None:
        now = time.time()
        if on:
            self.alone_spans.append([now, None])
        elif self.alone_spans and self.alone_spans[-1][1] is None:
            self.alone_spans[-1][1] = now

    def _alone_index(self, at: float) -> int | None:
        for i in range(len(self.alone_spans) - 1, -1, -1):
            start, end = self.alone_spans[i]
            if start <= at and (end is None or at <= end):
                return i
            if end is not None and end < at:
                return None
        return None

    # --- taking in --------------------------------------------------------------------------------
    def _new(self, key: str) -> list:
        """The payloads recorded on `key` since the last call; the list is cut to its newest KEEP."""
        bucket = self.run.recorded[key]
        n = len(bucket)
        new = bucket[self._seen[key]:n]
        cut = max(0, n - KEEP)
        del bucket[:cut]
        self._seen[key] = n - cut
        return new

    def take(self) -> Taken:
        keys, t = self.keys, self.taken
        for key, raw, at in self._new(keys.input):
            msg = decoded(Input, key, raw)
            if msg is not None:
                t.inputs.append((msg.stamp, at))
                self._inputs[msg.tick] = (msg.x, msg.stamp, at)
                self._inputs.move_to_end(msg.tick)
                while len(self._inputs) > RECENT_INPUTS:
                    self._inputs.popitem(last=False)
        for key, raw, at in self._new(f"{keys.prefix}/proposal/learner/*"):
            msg = decoded(Proposal, key, raw)
            if msg is not None:
                t.learned[key.rsplit("/", 1)[-1]] = msg.learned
                seen = self._inputs.get(msg.tick)
                if seen is not None:
                    t.answers.append((at, at - seen[2]))
        for key, raw, at in self._new(keys.command):
            msg = decoded(Command, key, raw)
            if msg is None:
                continue
            t.ticks.append((at, at - msg.stamp, msg.mode))
            span, seen = self._alone_index(at), self._inputs.get(msg.tick)
            if span is not None and msg.mode != "teacher" and seen is not None:
                error = self.judge(seen[0], msg.y)
                if error is not None:  # (not the learner's: held, its answer past the deadline, or a default's)
                    t.errors.append((at, span, error, msg.source.startswith("learner/")))
                    if t.judged[0] != span:
                        t.judged = (span, [])
                    t.judged[1].append(seen[0])
        for key, raw, _ in self._new(keys.train):
            msg = decoded(TrainingPair, key, raw)
            if msg is not None and msg.epoch in t.epochs:  # an epoch an arbitrator's status named
                t.epochs[msg.epoch] = max(t.epochs[msg.epoch], msg.seq)
        for key, raw, at in self._new(self.status_key):
            msg = decoded(Status, key, raw)
            if msg is not None and key.endswith(f"/{msg.role}/{msg.name}"):
                t.statuses[f"{msg.role}/{msg.name}"] = (msg, at)
                epoch, seq = msg.state.get("epoch"), msg.state.get("seq")
                if msg.role == "arbitrator" and isinstance(epoch, str) and isinstance(seq, int):
                    t.epochs[epoch] = max(seq, t.epochs.get(epoch, 0))
        with self._lock:
            t.tokens += self._tokens
            self._tokens.clear()
        return t

    # --- reading what was taken in ----------------------------------------------------------------
    def status(self, member: str) -> Status | None:
        found = self.taken.statuses.get(member)
        return found[0] if found else None

    def counter(self, member: str, name: str, default: int = 0) -> int:
        status = self.status(member)
        return int(status.counters.get(name, default)) if status else default

    def serving_learner(self) -> str:
        """The learner the arbitrator listens to, as its newest status says."""
        status = self.status("arbitrator/arbitrator")
        return str(status.state.get("learner", "")) if status else ""

    def taught(self) -> int:
        """Pairs the arbitrators numbered, every run of them (each restart begins an epoch)."""
        return sum(self.taken.epochs.values())

    def rejected(self) -> dict[str, int]:
        return {m: int(s.counters.get("rejected", 0)) for m, (s, _) in self.taken.statuses.items()}

    def back_at(self, token: str, after: float) -> float | None:
        """When liveliness token `token` was first declared after time `after` (a service killed then is
        back, ready, when its token is)."""
        return next((at for key, kind, at in self.taken.tokens if key == token and kind == "PUT" and at > after), None)

    def teaching(self, since: float) -> set[str] | None:
        """Who teaches, as the arbitrator's newest status says, if it was heard after `since`."""
        found = self.taken.statuses.get("arbitrator/arbitrator")
        if found is None or found[1] <= since:
            return None
        return set(found[0].state.get("teaching", []))

    def close(self) -> None:
        for held in self._held:
            held.undeclare()
