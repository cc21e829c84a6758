"""The learner box: serves any learner of services.learners on the bus.

It answers each newest input with a prediction and a confidence, and learns every training pair
(lossless, numbered (epoch, seq): a gap is filled from the arbitrator's recent pairs). It serves
its snapshot and its history so a replacement can be warmed (hot-swap), and with --state-dir it
logs every pair to a file and replays it after a crash, so a restart forgets nothing.

What it has to learn at once (the log after a restart, the old learner's history at a hot-swap) it
learns in slices between answers, saying it is unsure (confidence 0) until it has caught up: an hour
of mirroring took a GP minutes to learn again, and a learner that learned it all before serving was
stopped at its ready timeout, again and again, for good (benchmarks/soak.py). So do the pairs of a batch
beyond LIVE_LEARN_S (a loaded learner that fell behind): its answers never stop for long.
"""
from __future__ import annotations

import argparse
import collections
import math
import time
from pathlib import Path

import numpy as np
import zenoh

from bus_schema import (InstanceKeys, Input, PairBatch, Proposal, SchemaError, Snapshot, TrainingPair, decode,
                        encode)
from services.arbitration.algorithm2 import learn_pair
from services.boxes.learner_warming import Warming
from services.boxes.numbers import COUNT
from services.bus.config import add_bus_args, config_from_args
from services.bus.inbox import decode_or_reject
from services.bus.queries import ask_owner
from services.bus.runtime import BoxRuntime
from services.learners import DEFAULT_LEARNER, LEARNERS, compile_kernels, make_learner, start_upkeep, \
    stop_upkeep
from services.pairlog import PairLog, PairLogError
from services.placement import take_own_cpus, to_every_cpu
from services.priority import ShareWatch, stop_yielding, yield_cpus
from services.params import parse_params


class LearnerNode(Warming):
    """The box's state and handlers: one learner, its pair log and its place in the training epoch (warming: its
    Warming part)."""

    def __init__(self, box: BoxRuntime, model, pairlog: PairLog, output_space):
        self.box, self.session, self.keys, self.name, self.log = box, box.session, box.keys, box.name, box.log
        self.model, self.pairs = model, pairlog
        self.output_space = output_space  # every proposal is clipped to it
        self.dims = {"x": model.n_in, "y": model.n_out, "mask": model.n_out}
        self.input_dims = {"x": model.n_in}
        self.epoch, self.seq = "", 0  # the last pair taken in (logged; learned once the backlog is)
        self.backlog: collections.deque = collections.deque()  # (x, y, mask, source) taken in, yet to be learned
        self._catching_up_since = None  # monotonic, while a backlog is learned
        self.serving_live = False  # the model's upkeep off the answer path: once its first catch-up is done
        self._last_confirm = -math.inf  # when a jump in seq was last put to the arbitrator (monotonic)
        self._learn_until = math.inf  # a batch's pairs are learned at once until then, the rest between answers
        self._upkeep_busy, self._next_upkeep_look = False, 0.0  # (tend_upkeep)
        self._yielding = False  # its session's group yielding (catching up before it serves)
        self._share: ShareWatch | None = None  # while yielding: whether it still gets a share of a core
        self.rejects, self.counts = box.rejects, box.counts
        self.pub = box.sensor_publisher(self.keys.proposal("learner", self.name))

    def handle(self, batch) -> None:
        """One batch: the newest input answered first (the tick is waiting; learning can follow), then
        the pairs learned in order; queries answered as they come."""
        newest, pairs = None, []
        for tag, key, raw, _ in batch:
            if tag == "input":
                newest = decode_or_reject(Input, raw, key, self.rejects, self.input_dims) or newest
            elif tag == "train":
                pair = decode_or_reject(TrainingPair, raw, key, self.rejects, self.dims)
                if pair is not None:
                    pairs.append(pair)
            else:
                self.on_query(raw)
        if newest is not None:
            self.answer(newest)
        self._learn_until = time.monotonic() + LIVE_LEARN_S
        for pair in pairs:
            self.on_pair(pair)
        if self.backlog:
            self.catch_up(CATCH_UP_SLICE_S)
        elif self._yielding and self.serving_live:
            self.stop_yielding()
        self.tend_upkeep()

    def tend_upkeep(self) -> None:
        """A status at once when the model's upkeep (the GP's fits) ends, not at the next second's: whoever waits for
        the fits to catch up (a person, `dogged ps`, a test) hears it when it happens. Looked at every UPKEEP_LOOK_S at
        most. (Landing ended fits here, Learner.land_upkeep every 0.2 s for 2 ms, was withdrawn: with it the hierarchy's
        learned gait walked 65 % of its ticks where it must 80, in 2 of 2 runs; 2 of 2 passed without.)"""
        now = time.monotonic()
        if now < self._next_upkeep_look:
            return
        self._next_upkeep_look = now + UPKEEP_LOOK_S
        busy = self.model.upkeep_under_way > 0
        if self._upkeep_busy and not busy:
            self.box.status.publish_soon()
        self._upkeep_busy = busy

    def wait(self) -> float:
        """How long the loop may wait for an event: not at all while a backlog is to be learned."""
        return 0.0 if self.backlog else 0.1

    # --- learning ---------------------------------------------------------------------------
    def learn(self, x, y, mask, source=None) -> None:
        if not learn_pair(self.model, x, y, mask, source):
            self.counts["partial_pairs_learned_whole"] += 1

    def incorporate(self, pair: TrainingPair):
        if self.backlog or time.monotonic() >= self._learn_until:
            # in order, behind what is yet to be learned; or, the batch's time to learn spent, between answers
            self.backlog.append((pair.x, pair.y, pair.mask, pair.source))
        else:
            self.learn(pair.x, pair.y, pair.mask, pair.source)
        self.pairs.append(pair)
        self.epoch, self.seq = pair.epoch, pair.seq
        self.counts["learned"] += 1

    def on_pair(self, pair: TrainingPair):
        if pair.epoch != self.epoch:
            # a new arbitrator run; once an epoch is known, a new one must be the arbitrator's: a stranger's
            # pair in an epoch of its own would otherwise be learned, and the real epoch's seqs reset
            if self.epoch and not self.confirmed(pair):
                self.rejects(self.keys.train,
                             ValueError(f"training pair of epoch {pair.epoch[:32]!r} (seq {pair.seq}), "
                                                         f"not {self.epoch}, and the arbitrator does not confirm it"))
                return
            self.log.info("training epoch %s begins (arbitrator started)", pair.epoch)
            self.epoch, self.seq = pair.epoch, 0
        if pair.seq <= self.seq:
            self.counts["duplicates"] += 1
            return
        if pair.seq > self.seq + PLAUSIBLE_GAP and not self.confirmed(pair):
            # a seq far ahead, unless the arbitrator has it, would make every later pair a "duplicate"
            self.rejects(self.keys.train, ValueError(f"training pair seq {pair.seq} jumps {pair.seq - self.seq} "
                                                     f"past {self.seq} and the arbitrator does not confirm it"))
            return
        if pair.seq > self.seq + 1:
            self.fill_gap(pair.seq - 1)
        self.incorporate(pair)

    def confirmed(self, pair: TrainingPair) -> bool:
        """Whether the arbitrator's recent pairs hold this very pair (its epoch, seq and input). At most
        one such query a second: a flood of hostile jumps must not stall the loop on queries."""
        now = time.monotonic()
        if now - self._last_confirm < 1.0:
            return False
        self._last_confirm = now
        batch = self.query(self.keys.train_recent, PairBatch, f"from={pair.seq};to={pair.seq}", timeout=1.0)
        return (batch is not None and batch.epoch == pair.epoch and batch.first_seq == pair.seq
                and len(batch.x) == 1 and np.array_equal(batch.x[0], pair.x))

    def fill_gap(self, last: int):
        first = self.seq + 1
        batch = self.query(self.keys.train_recent, PairBatch, f"from={first};to={last}")
        if batch is None or batch.epoch != self.epoch or batch.first_seq != first or len(batch.x) != last - first + 1:
            self.counts["pairs_lost"] += last - first + 1
            self.log.error("training pairs %d..%d of epoch %s are gone; learning goes on without them",
                           first, last, self.epoch)
            return
        sources = batch.sources() or ["gap-fill"] * len(batch.x)
        for i, (x, y, mask, source) in enumerate(zip(batch.x, batch.y, batch.mask, sources)):
            seq, mask = first + i, None if np.all(mask == 1) else mask
            self.incorporate(TrainingPair(self.epoch, seq, -1, x, y, source, mask))
        self.counts["gap_filled"] += len(batch.x)

    def query(self, key, cls, parameters="", timeout=5.0):
        """The owner's answer (the arbitrator's recent pairs, the old learner's snapshot or history): if
        another answers too, with something else, none is trusted (counted as a rejection)."""
        payload, problem = ask_owner(self.session, f"{key}?{parameters}" if parameters else key, timeout)
        if payload is None:
            if "different answers" in problem:
                self.rejects(key, ValueError(problem))
            return None
        try:
            return decode(cls, payload, key, self.dims)
        except SchemaError as err:
            self.rejects(key, err)
            return None

    def catch_up(self, budget_s: float) -> None:
        """Learn the backlog for about budget_s (at least one pair), oldest first."""
        if self._catching_up_since is None:
            self._catching_up_since = time.monotonic()
            self.log.info("learning %d pairs between answers (unsure until then)", len(self.backlog))
            if not self.serving_live:  # not serving yet: minutes of a core's work, on every CPU it is given, taking
                to_every_cpu()  # of each what the others leave (services/priority.py)
                self._yielding, self._share = yield_cpus(), ShareWatch()
        elif self._yielding and not self.serving_live and self._share.starved():
            self.counts["yield_starved"] += 1
            self.log.info("the machine is full (%.0f %% of a core in %.0f s): learning at the tick path's priority",
                          100 * self._share.last_share, self._share.window_s)
            self.stop_yielding()
        end = time.monotonic() + budget_s
        while self.backlog:
            # a pair at a time, as `dogged replay` learns them: before serving live the model learns as offline, where
            # chunks bought nothing (a swap's history in learn_many's of 256 rows was 21.6 s for 23,046 pairs, 21.9 s
            # a pair at a time, the same model)
            self.learn(*self.backlog.popleft())
            if time.monotonic() >= end:
                break
        if not self.backlog:
            took = time.monotonic() - self._catching_up_since
            self.counts["caught_up_s"] = round(took, 3)
            self.log.info("caught up: %d pairs learned (%.1f s)", self.model.n_learned, took)
            self._catching_up_since = None
            self.serve_live_once_caught_up()
            self.box.status.publish_soon()

    def serve_live_once_caught_up(self) -> None:
        """The model's upkeep (the GP's fits) moves off the answer path once the model has learned what it
        started with (an earlier run's log, the old learner's history): that is learned as offline, fits inline
        at the counts an offline replay fits at, so a restart or a swap relearns exactly what `dogged replay`
        would. Learned live, fits ran behind the fast catch-up: the ball-seeking soak's 23,272 pairs of history
        gave a GP that erred 0.0080, 0.0316 and 0.0448 on the last span's inputs (three runs, the last paced on its
        fits), 0.0070 offline."""
        if not self.backlog and not self.serving_live:
            self.model.serve_live()
            self.serving_live = True
            take_own_cpus()  # back on the tick path's, if it was moved off them
            self.stop_yielding()

    def stop_yielding(self) -> None:
        """Back to the tick path's priority (serving, or the machine full): tried for a tenth of a second, then once
        a batch while the kernel refuses (it allows one change in 100 ms, over all processes)."""
        if self._yielding:
            first = self.counts["stop_yielding_tries"] == 0
            self.counts["stop_yielding_tries"] += 1
            self._yielding = not stop_yielding(tries=5 if first else 1)
            if self._yielding and first:
                self.log.warning("still yielding (the kernel refused): trying again at each batch")

    @property
    def learned_seq(self) -> int:
        """The seq of the last pair learned (the log's pairs are numbered without gaps up to self.seq)."""
        return self.seq - len(self.backlog)

    # --- serving ----------------------------------------------------------------------------
    def answer(self, msg: Input):
        p = self.model.predict_one(msg.x)
        y = self.output_space.clip(p.y)
        if not np.array_equal(y, p.y):
            self.counts["clipped"] += 1  # the learner's own bound is its taught range; the robot's is this
        confidence = 0.0 if self.backlog else float(p.confidence)  # not yet all it was taught: unsure
        self.pub.put(encode(Proposal(msg.tick, f"learner/{self.name}", y, confidence, learned=self.model.n_learned,
                                     backlog=len(self.backlog))))
        self.counts["proposals"] += 1

    def on_query(self, query: zenoh.Query):
        key = str(query.key_expr)
        if key == self.keys.snapshot(self.name):
            # what the model has learned: the history's first rows up to learned_seq (the rest is its backlog)
            query.reply(key, encode(Snapshot(type(self.model).__name__, self.epoch, self.learned_seq,
                                             len(self.pairs) - len(self.backlog), self.model.snapshot())))
            return
        params = query.parameters
        problem = history_query_problem(params)
        if problem:
            self.rejects(key, ValueError(problem))
            query.reply_err(problem.encode())
            return
        n = len(self.pairs)
        upto = params.get("upto")
        if upto is not None and params.get("epoch") == self.epoch:
            n -= max(0, self.seq - int(upto))  # the rows learned after `upto`
        query.reply(key, encode(PairBatch(self.epoch, self.seq - len(self.pairs) + 1, *self.pairs.history(n))))

    def report(self):
        counters = {"seq": self.seq, "pairs": len(self.pairs), "backlog": len(self.backlog),
                    "upkeep_under_way": int(self.model.upkeep_under_way)}
        return counters, {"learner": type(self.model).__name__, "epoch": self.epoch, "size": int(self.model.size),
                          "params": {k: v if isinstance(v, (int, float, str, bool)) else repr(v)
                                     for k, v in self.model.get_params().items()}}


# a backlog is learned this long at a time between answers: an input waits at most about this for its answer
CATCH_UP_SLICE_S = 0.005
UPKEEP_LOOK_S = 0.2  # how often it looks whether the model's fits have ended (tend_upkeep)
# a batch's pairs are learned at once for this long; the rest join the backlog. Learned whole, the pairs a loaded
# learner had fallen behind on came in one batch as the teacher let go, its answers stopped for a fifth of a second,
# the arbitrator stopped waiting for it and the lockstep simulation ran 43 ticks with the head held (CI, mirroring)
LIVE_LEARN_S = 0.010
PLAUSIBLE_GAP = 65536  # the arbitrator's recent pairs: a longer jump in seq must be confirmed by it


def history_query_problem(params) -> str:
    """What is wrong with a history query's parameters (epoch=<id>;upto=<seq>), or ''."""
    for name, value in params:
        if name == "upto" and not (value.isdigit() and len(value) <= 18):
            return f"history: upto must be a sequence number, got {value[:32]!r}"
        if name == "epoch" and len(value) > 64:
            return "history: epoch longer than 64 characters"
        if name not in ("upto", "epoch"):
            return f"history: unknown parameter {name[:32]!r}; known: epoch, upto"
    return ""


def main(conf: zenoh.Config, instance: str, learner: str, params: dict, name: str = "learner", seed: int = 0,
         state_dir: str | None = None, warm_from: str | None = None) -> int:
    try:
        return serve(conf, instance, learner, params, name, seed, state_dir, warm_from)
    finally:
        stop_upkeep()  # fits still queued are dropped: what was learned is in the pair log


def serve(conf: zenoh.Config, instance: str, learner: str, params: dict, name: str, seed: int,
          state_dir: str | None, warm_from: str | None) -> int:
    with BoxRuntime(conf, InstanceKeys(instance), "learner", name) as box:
        spaces = box.fetch_spaces()
        if spaces is None:
            return 0
        model = make_learner(learner, n_in=spaces.input.dims, n_out=spaces.output.dims, seed=seed, **params)
        compile_kernels(model)
        start_upkeep(model)  # the fitting processes with the service; the model serves live once caught up
        pairlog = PairLog(model.n_in, model.n_out, Path(state_dir) / f"{name}.pairs" if state_dir else None)
        node = LearnerNode(box, model, pairlog, spaces.output)
        box.subscribe(box.keys.train, "train")  # before warming: pairs published meanwhile wait, none is missed
        try:
            saved = pairlog.replay_file()
        except PairLogError as err:
            box.log.error("%s", err)
            return 1
        if saved:
            node.replay(saved)
            box.log.info("replaying %d pairs from %s between answers", len(saved), pairlog.path)
        elif warm_from:
            node.warm_from(warm_from)
        node.serve_live_once_caught_up()  # at once if it starts with nothing to learn
        box.subscribe(box.keys.input, "input")
        box.queryable(box.keys.snapshot(name), "query")
        box.queryable(box.keys.history(name), "query")
        box.log.info("%s serving %d -> %d (%d pairs known)", learner, model.n_in, model.n_out, len(pairlog))
        for batch in box.batches(node.wait, node.report):
            node.handle(batch)
        pairlog.close()
    return 0


def arg_parser() -> argparse.ArgumentParser:
    """The one reading of `dogged run learner`'s arguments (a profile's are read with it too)."""
    parser = argparse.ArgumentParser(prog="dogged run learner", description=__doc__.splitlines()[0])
    parser.add_argument("--instance", default="main")
    parser.add_argument("--name", default="learner")
    parser.add_argument("--learner", default=DEFAULT_LEARNER, help=f"one of: {', '.join(sorted(LEARNERS))}")
    parser.add_argument("--param", action="append", help="hyper-parameter name=value (repeatable)")
    parser.add_argument("--seed", type=COUNT, default=0)
    parser.add_argument("--state-dir", default=None, help="log pairs here and replay them after a restart")
    parser.add_argument("--warm-from", default=None, help="hot-swap: take over from this learner")
    add_bus_args(parser)
    return parser


def cli(argv=None) -> int:
    parser = arg_parser()
    args = parser.parse_args(argv)
    if args.learner not in LEARNERS:
        parser.error(f"--learner: unknown learner {args.learner!r}; known: {', '.join(sorted(LEARNERS))}")
    return main(config_from_args(args), args.instance, args.learner, parse_params(args.param), args.name,
                args.seed, args.state_dir, args.warm_from)
