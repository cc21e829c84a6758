"""The arbitrator box: Algorithm 2, steps 2-7, as a service.

Per tick it gathers the teaching teachers', the active learner's and any default controller's
proposals up to a deadline, picks the output with a strategy, publishes the command (with the
mode) and, when a teacher spoke, the training pair. Membership comes from liveliness tokens, so
it never waits for a process that is gone; a member alive but silent (frozen, or a token with nobody
behind it) stops being waited for after MISSES_BEFORE_IGNORED deadlines in a row, until it answers.
"""
from __future__ import annotations

import argparse
import collections
import time
import uuid

import numpy as np
import zenoh

from bus_schema import Command, InstanceKeys, Input, PairBatch, Proposal, SelectLearner, TrainingPair, encode
from bus_schema.spaces import in_lockstep
from services.arbitration.algorithm2 import decide, trains
from services.arbitration.recent_pairs import RecentPairs
from services.arbitration.strategies import STRATEGIES, make_strategy
from services.arbitration.ticks import TickTable
from services.boxes.common import Membership
from services.boxes.numbers import number
from services.bus.config import add_bus_args, config_from_args
from services.bus.inbox import decode_or_reject
from services.bus.runtime import BoxRuntime

MISSES_BEFORE_IGNORED = 5
DEADLINE_MS = 20.0  # how long a tick waits for its members, by default: within a 30 Hz robot's tick
# a platform in lockstep (--rate 0) has no real time to keep: its arbitrator waits longer by default. At 20 ms a
# learner stalled for a fifth of a second (descheduled on a loaded machine) missed five deadlines in a row and was
# no longer waited for, and the simulation, racing on at hundreds of ticks a second without it, held the
# mirroring head for 43 ticks (CI); at 100 ms such a stall costs two ticks held
LOCKSTEP_DEADLINE_MS = 100.0


def deadline_ms_for(spaces, asked_ms: float | None) -> float:
    """The tick's wait: `--deadline-ms` where given, else by the platform's pace (its spaces say lockstep)."""
    if asked_ms is not None:
        return asked_ms
    return LOCKSTEP_DEADLINE_MS if in_lockstep(spaces) else DEADLINE_MS


class Arbitrator:
    """The box's state and handlers, on its runtime (the session, its members' events, its status)."""

    def __init__(self, box: BoxRuntime, spaces, strategy, deadline_s, learner, train_on, recent):
        self.box, self.keys, self.log = box, box.keys, box.log
        self.dims = {"x": spaces.input.dims, "y": spaces.output.dims}
        self.output_space = spaces.output  # every command, and so every pair learned, is clipped to it
        self.choice = spaces.extra.get("choice") == "largest"  # one output per action: a teacher's is one-hot
        self.strategy, self.train_on = strategy, train_on
        self.table = TickTable(deadline_s)
        self.members = Membership(self.keys)
        self.selected = learner
        self.epoch, self.seq = uuid.uuid4().hex[:12], 0
        self.recent = RecentPairs(recent, spaces.input.dims, spaces.output.dims)
        self.missed: collections.Counter[str] = collections.Counter()  # deadlines missed in a row, per member
        self.last_command = np.zeros(spaces.output.dims)
        self.rejects, self.counts = box.rejects, box.counts
        self.command_pub = box.sensor_publisher(self.keys.command)
        self.train_pub = box.lossless_publisher(self.keys.train)
        self.commanding = None  # declared once a platform hears our commands: platforms wait for it to tick
        self.handlers = {"input": self.on_input, "proposal": self.on_proposal, "select": self.on_select}

    # --- membership -------------------------------------------------------------------------
    def active_learner(self) -> str | None:
        learners = self.members.names("learner")
        if self.selected in learners:
            return self.selected
        # the selected learner is gone (or none was chosen): the longest-lived learner serves
        for member in self.members.order:
            role, name = member.split("/", 1)
            if role == "learner":
                return name
        return None

    def expected(self) -> set[str]:
        out = {f"teacher/{n}" for n in self.members.names("teaching")}
        out |= {f"default/{n}" for n in self.members.names("default")}
        learner = self.active_learner()
        if learner is not None:
            out.add(f"learner/{learner}")
        return {member for member in out if self.missed[member] < MISSES_BEFORE_IGNORED}

    def speaking(self, entry, role: str, token: str) -> list:
        """The tick's proposals from members of `role` that hold their `token` (a teacher switched on, a
        default controller alive) and said something; a proposal from anyone else is counted, unused."""
        holders = self.members.names(token)
        out = []
        for member, p in entry.proposals.items():
            kind, _, name = member.partition("/")
            if kind != role or p.y is None:
                continue
            if name in holders:
                out.append((member, p))
            else:
                self.counts[f"{role}_proposals_without_token"] += 1
        return out

    def on_alive(self, key, kind):
        parsed = self.members.update(key, kind)
        if parsed is not None:  # a member that came or went starts afresh
            role, name = parsed
            self.missed.pop(f"{'teacher' if role == 'teaching' else role}/{name}", None)

    def silent(self) -> list[str]:
        """Members alive but not waited for: they missed MISSES_BEFORE_IGNORED deadlines in a row."""
        return sorted(member for member, n in self.missed.items() if n >= MISSES_BEFORE_IGNORED)

    # --- handlers ---------------------------------------------------------------------------
    def on_input(self, key, raw, now):
        msg = decode_or_reject(Input, raw, key, self.rejects, {"x": self.dims["x"]})
        if msg is None:
            return
        try:
            self.table.add_input(msg.tick, msg.stamp, msg.x, now)
        except ValueError as err:
            self.rejects(key, err)
            return
        self.counts["inputs"] += 1

    def on_proposal(self, key, raw, now):
        parts = key.split("/")
        if len(parts) != 5 or parts[3] not in ("teacher", "learner", "default"):
            self.rejects(key, ValueError(f"{key}: not a proposal key (dl/<i>/proposal/<role>/<name>)"))
            return
        msg = decode_or_reject(Proposal, raw, key, self.rejects, {"y": self.dims["y"]})
        if msg is not None:
            self.counts["proposals"] += 1
            member = f"{parts[3]}/{parts[4]}"
            if self.missed.pop(member, 0) >= MISSES_BEFORE_IGNORED:  # it answers: waited for again
                self.box.status.publish_soon()  # who is waited for changed: say so now, not in a second
            self.table.add_proposal(member, msg, now)

    def on_select(self, key, raw, now):
        msg = decode_or_reject(SelectLearner, raw, key, self.rejects)
        if msg is not None and msg.learner != self.selected:  # (a swap says it again until confirmed)
            self.log.info("learner %s serves from now on (was %s)", msg.learner, self.active_learner())
            self.selected = msg.learner
            self.counts["swaps"] += 1
            self.box.status.publish_soon()  # the swap waits for this status: now, not in a second

    def on_recent_query(self, query: zenoh.Query):
        """Gap filling: the training pairs of this epoch with seq in [from, to] still in memory."""
        params = query.parameters
        try:
            first, last = int(params.get("from", "1")), int(params.get("to", str(self.seq)))
        except ValueError:
            self.rejects(self.keys.train_recent, ValueError(f"recent query parameters {str(params)[:80]!r}: "
                                                            "from and to must be integers"))
            query.reply_err(b"from and to must be integers")
            return
        query.reply(self.keys.train_recent, encode(PairBatch(self.epoch, *self.recent.rows(first, last))))

    # --- the loop ---------------------------------------------------------------------------
    def wait(self) -> float:
        """How long the loop may wait for an event: until the oldest tick's deadline, at most 50 ms."""
        deadline = self.table.next_deadline()
        return 0.05 if deadline is None else min(0.05, max(0.0, deadline - time.monotonic()))

    def handle(self, batch) -> None:
        """One batch: each event handled, then any tick now complete or past its deadline decided."""
        handlers, now = self.handlers, None
        for tag, key, raw, kind in batch:
            now = time.monotonic()
            if tag == "alive":
                self.on_alive(key, kind)
            elif tag == "recent":
                self.on_recent_query(raw)
            else:
                handlers[tag](key, raw, now)
            self.decide_ready(now)
        if now is None:  # nothing heard: the wait ended at a deadline
            self.decide_ready(time.monotonic())
        if self.commanding is None and self.command_pub.matching_status.matching:  # off the tick's path
            self.commanding = self.box.token(self.keys.commanding(self.box.name))

    # --- deciding ---------------------------------------------------------------------------
    def decide_ready(self, now):
        if not len(self.table):
            return
        expected = self.expected()
        learner = self.active_learner()
        for entry in self.table.ready(expected, now):
            if not expected.issubset(entry.proposals):
                self.counts["deadline_misses"] += 1
                for member in expected - entry.proposals.keys():
                    self.missed[member] += 1
                    if self.missed[member] == MISSES_BEFORE_IGNORED:
                        self.log.warning("%s missed %d deadlines in a row: not waited for until it answers", member,
                                         MISSES_BEFORE_IGNORED)
                        self.counts["members_silenced"] += 1
                        self.box.status.publish_soon()
            teachers = self.speaking(entry, "teacher", "teaching")
            mine = f"learner/{learner}"
            learner_p = (mine, entry.proposals[mine]) if mine in entry.proposals else None
            # past the deadline, while the learner is not waited for, or with none alive: the tick went on without it
            self.counts["without_learner"] += learner_p is None
            defaults = self.speaking(entry, "default", "default")
            d, clipped = decide(self.strategy, teachers, learner_p, defaults[0] if defaults else None,
                                self.last_command, self.output_space, self.choice)
            self.counts["clipped_commands"] += clipped
            self.last_command = d.y
            self.command_pub.put(encode(Command(entry.tick, entry.stamp, d.y, d.mode, d.source, d.confidence)))
            self.counts["commands"] += 1
            self.counts[f"mode_{d.mode}"] += 1
            if trains(d, self.train_on):
                self.publish_pair(entry.tick, entry.x, d.y, d.source, d.mask)

    def publish_pair(self, tick, x, y, source, mask=None):
        self.seq += 1
        pair = TrainingPair(self.epoch, self.seq, tick, x, np.asarray(y, dtype=np.float64), source, mask)
        self.recent.append(self.seq, x, pair.y, mask, source)
        self.train_pub.put(encode(pair))
        self.counts["train_pairs"] += 1

    def report(self) -> tuple[dict, dict]:
        counters = {"late_proposals": self.table.late}
        state = {"learner": self.active_learner() or "", "epoch": self.epoch, "seq": self.seq,
                 "pending": len(self.table), "deadline_ms": round(self.table.deadline_s * 1000.0, 3),
                 "teaching": sorted(self.members.names("teaching")), "rejected_by_key": dict(self.rejects.counts),
                 "not_waited_for": self.silent()}
        return counters, state


def main(conf: zenoh.Config, instance: str, name: str = "arbitrator", strategy: str = "teacher-first",
         unsure_below: float = 0.25, deadline_ms: float | None = None, learner: str | None = None,
         train_on: str = "teacher", recent: int = 65536, strategy_params: dict | None = None) -> int:
    with BoxRuntime(conf, InstanceKeys(instance), "arbitrator", name) as box:
        chooser = make_strategy(strategy, unsure_below=unsure_below, **(strategy_params or {}))
        spaces = box.fetch_spaces()
        if spaces is None:
            return 0
        deadline_ms = deadline_ms_for(spaces, deadline_ms)
        arb = Arbitrator(box, spaces, chooser, deadline_ms / 1000.0, learner, train_on, recent)
        box.subscribe_alive(box.keys.alive_all, "alive")
        box.subscribe(box.keys.input, "input")
        box.subscribe(box.keys.proposals, "proposal")
        box.subscribe(box.keys.select_learner, "select")
        box.queryable(box.keys.train_recent, "recent")
        box.log.info("arbitrating %d -> %d dims with %s (unsure below %.2f), waiting %.0f ms a tick%s",
                     spaces.input.dims, spaces.output.dims, strategy, unsure_below, deadline_ms,
                     " (the platform is in lockstep)" if in_lockstep(spaces) else "")
        for batch in box.batches(arb.wait, arb.report):
            arb.handle(batch)
    return 0


def arg_parser() -> argparse.ArgumentParser:
    """The one reading of `dogged run arbitrator`'s arguments (a profile's are read with it too)."""
    parser = argparse.ArgumentParser(prog="dogged run arbitrator", description=__doc__.splitlines()[0])
    parser.add_argument("--instance", default="main")
    parser.add_argument("--name", default="arbitrator")
    parser.add_argument("--strategy", choices=sorted(STRATEGIES), default="teacher-first")
    parser.add_argument("--unsure-below", type=number(at_least=0.0, at_most=1.0), default=0.25,
                        help="learner confidence that means 'unsure'")
    parser.add_argument("--deadline-ms", type=number(above=0.0, at_most=60_000.0), default=None,
                        help=f"how long a tick waits for proposals (default: {DEADLINE_MS:g}; "
                             f"{LOCKSTEP_DEADLINE_MS:g} when the platform runs in lockstep)")
    parser.add_argument("--learner", default=None, help="the learner that serves first (default: the oldest alive)")
    parser.add_argument("--train-on", choices=("teacher", "all"), default="teacher",
                        help="teacher: only teacher outputs train the learner; "
                             "all: every output does (Alg. 2 literally)")
    parser.add_argument("--error-threshold", type=number(at_least=0.0), default=None,
                        help="predictive strategy (Algorithm 1)")
    add_bus_args(parser)
    return parser


def cli(argv=None) -> int:
    parser = arg_parser()
    args = parser.parse_args(argv)
    params = {"error_threshold": args.error_threshold} if args.error_threshold is not None else {}
    return main(config_from_args(args), args.instance, args.name, args.strategy, args.unsure_below,
                args.deadline_ms, args.learner, args.train_on, strategy_params=params)
