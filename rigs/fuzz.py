"""Ten thousand malformed and hostile payloads and query parameters over a running deployment, with a
teacher teaching (issue 12): every one must be refused and counted by whoever reads it, and nothing
may exit, restart, stop learning or slow the loop.

The deployment is the fault suite's (rigs/faults.py): the simulated Aibo mirroring at
30 Hz under the supervisor. The fuzzer is one client session that knows only the bus schema. Each
case names the key, the payload and the services that must count it as rejected; the suite compares
every service's `rejected` counter before and after against those expectations, exactly.
"""
from __future__ import annotations

import json
import subprocess
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import msgpack
import numpy as np
import zenoh

from bus_schema import (ArenaReset, Clock, Command, ControlReply, Handle, Input, Proposal, SelectLearner, Status,
                        TeachSwitch, TrainingPair, decode, encode)
from bus_schema.keys import supervisor_key
from rigs.faults import mirroring_profile
from rigs.live.mirroring import student_error
from services.bus.publishers import wait_matching
from services.demo.live import LiveRun, decoded

N_IN = N_OUT = 18  # the mirroring deployment's spaces
FAR_TICKS = (2 ** 63 - 1, 2 ** 62, 10 ** 15)


@dataclass
class Case:
    key: str
    payload: bytes
    counted_by: tuple[str, ...]  # services whose `rejected` counter must grow by one (the supervisor: ps "refused")
    what: str


@dataclass
class Query:
    selector: str
    what: str
    counted_by: tuple[str, ...] = ()  # services that count it rejected (the supervisor counts in ps "refused")


@dataclass
class FuzzResult:
    sent: Counter = field(default_factory=Counter)  # per kind of case
    expected: Counter = field(default_factory=Counter)  # per service: rejections due
    counted: dict = field(default_factory=dict)  # per service: rejections seen
    query_errors: int = 0
    queries: int = 0
    supervisor_refused: int = 0
    restarts: dict = field(default_factory=dict)
    pids_kept: bool = False
    rate_before: float = 0.0
    rate_during: float = 0.0
    learned_before_fuzz: int = 0
    learned_after_fuzz: int = 0
    learned_at_end: int = 0
    student_rms_after: float = float("nan")
    latency_ms_before: float = float("nan")  # median input -> command, before and with a ghost teacher
    latency_ms_ghost: float = float("nan")


# --- payloads ------------------------------------------------------------------------------------
def sample(rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.uniform(-1.0, 1.0, n)


def valid(cls, rng: np.random.Generator, tick: int = 1):
    """A well-formed message of `cls` for the mirroring deployment."""
    return {
        Input: lambda: Input(tick, time.time(), sample(rng, N_IN)),
        Proposal: lambda: Proposal(tick, "teacher/fuzz", sample(rng, N_OUT), 1.0),
        Command: lambda: Command(tick, time.time(), sample(rng, N_OUT), "student", "fuzz", 1.0),
        TrainingPair: lambda: TrainingPair("fuzz", 1, tick, sample(rng, N_IN), sample(rng, N_OUT), "teacher/fuzz"),
        TeachSwitch: lambda: TeachSwitch("", True),
        SelectLearner: lambda: SelectLearner("learner"),
        Handle: lambda: Handle(np.zeros(18), np.zeros(18)),
        ArenaReset: lambda: ArenaReset(1, {}),
        Clock: lambda: Clock(1.0, time.time()),
        Status: lambda: Status("fuzz", "fuzz", 1, {}, {}),
    }[cls]()


def malformed(cls, rng: np.random.Generator) -> tuple[bytes, str]:
    """A payload no `cls` decoder may accept, and what is wrong with it."""
    fields = dict(cls.FIELDS)
    base = msgpack.unpackb(encode(valid(cls, rng)), raw=False)
    kind = int(rng.integers(9))
    if kind == 0:
        return rng.bytes(int(rng.integers(0, 200))), "random bytes"
    if kind == 1:
        return msgpack.packb(rng.uniform(-1e9, 1e9, int(rng.integers(0, 5))).tolist()), "not a map"
    if kind == 2:
        return msgpack.packb({**base, "v": int(rng.choice([0, 2, 99, -1]))}), "unknown schema version"
    if kind == 3:  # (a field added later, with a default, may be missing: an older sender's message)
        gone = str(rng.choice([name for name in fields if name not in getattr(cls, "DEFAULTS", {})]))
        return msgpack.packb({k: v for k, v in base.items() if k != gone}), "a field missing"
    if kind == 4:
        name = str(rng.choice(list(fields)))
        return msgpack.packb({**base, name: "x" * int(rng.integers(1, 50)) if fields[name] != "str" else 7}), \
            "a field of the wrong type"
    vectors = [n for n, k in cls.FIELDS if k in ("vector", "vectors")]
    if kind == 5 and vectors:
        name = str(rng.choice(vectors))
        values = np.frombuffer(base[name], "<f8").copy()
        values[int(rng.integers(len(values)))] = rng.choice([np.nan, np.inf, -np.inf])
        return msgpack.packb({**base, name: values.tobytes()}), "NaN or inf"
    if kind == 6 and vectors:
        name = str(rng.choice(vectors))
        wrong = int(rng.choice([0, 1, 17, 19, 5000]))
        return msgpack.packb({**base, name: np.zeros(wrong).tobytes()}), "a vector of the wrong length"
    scalars = [n for n, k in cls.FIELDS if k in ("int", "float", "str", "bool", "map")]
    if kind == 7 or not scalars:
        if rng.random() < 0.1:  # a tenth of these: 300 KiB, over every payload limit but the bulk ones'
            return rng.bytes(300 * 1024), "oversized"
        return rng.bytes(int(rng.integers(1, 64))), "random bytes"
    return msgpack.packb({**base, str(rng.choice(scalars)): None}), "nil where a value is due"


def hostile(cls, rng: np.random.Generator, epoch: str, seq: int) -> tuple[bytes, str]:
    """A well-formed payload with a value no service may trust."""
    if cls is Command:
        return encode(valid(Command, rng, int(rng.choice(FAR_TICKS)))), "a command for a tick from the far future"
    if cls is Input:
        return encode(valid(Input, rng, int(rng.choice(FAR_TICKS)))), "an input tick from the far future"
    if cls is TrainingPair:
        if rng.random() < 0.5:
            return encode(TrainingPair(f"fuzz{int(rng.integers(1000))}", int(rng.integers(1, 100)), 1, sample(rng,
                                                                                                              N_IN),
                                       sample(rng, N_OUT), "teacher/fuzz")), "a pair in an epoch of its own"
        jump = seq + int(rng.choice([10 ** 9, 10 ** 12, 2 ** 62]))
        return encode(TrainingPair(epoch, jump, 1, sample(rng, N_IN), sample(rng, N_OUT), "teacher/fuzz")), \
            "a pair whose seq jumps by a billion or more"
    if cls is ArenaReset:
        return encode(rng.choice([ArenaReset(-1, {}), ArenaReset(2 ** 40, {}), ArenaReset(1, {"pink": [1e9, 0.0]}),
                                  ArenaReset(1, {f"b{i}": [0.0, 0.0] for i in range(40)})])), "a hostile arena reset"
    raise ValueError(cls)


def cases(rng: np.random.Generator, keys, robot, n: int, epoch: str, seq: int) -> list[Case]:
    """`n` cases over every key a service reads, each with who must count it."""
    # (key, class, who counts a malformed one, who counts a hostile one or None); the recorder reads every key
    # the bus publishes on, and checks what it records as strictly as the services that read it
    targets = [
        (keys.input, Input, ("arbitrator", "learner", "mirror", "recorder"), ("arbitrator",)),
        (keys.proposal("teacher", "fuzz"), Proposal, ("arbitrator", "recorder"), None),
        (keys.proposal("learner", "fuzz"), Proposal, ("arbitrator", "recorder"), None),
        (f"{keys.prefix}/proposal/fuzz", Proposal, ("arbitrator",), None),  # not a proposal key at all
        (keys.command, Command, ("aibo", "recorder"), ("aibo",)),
        (keys.train, TrainingPair, ("learner", "recorder"), ("learner",)),
        (keys.teach, TeachSwitch, ("mirror", "recorder"), None),
        (keys.select_learner, SelectLearner, ("arbitrator", "recorder"), None),
        (robot.handle, Handle, ("aibo", "recorder"), None),
        (robot.arena, ArenaReset, ("aibo", "recorder"), ("aibo", "recorder")),  # (the schema's own check)
        (robot.clock, Clock, ("handler", "recorder"), None),
        (keys.status("fuzz", "fuzz"), Status, ("supervisor", "recorder"), None),  # in ps: "refused" "status"
    ]
    out = []
    for i in range(n):
        key, cls, counted, hostile_counted = targets[i % len(targets)]
        if hostile_counted is not None and rng.random() < 0.25:
            payload, what = hostile(cls, rng, epoch, seq)
            out.append(Case(key, payload, hostile_counted, what))
        else:
            payload, what = malformed(cls, rng)
            out.append(Case(key, payload, counted, what))
    return out


def queries(rng: np.random.Generator, keys, profile: str, n: int) -> list[Query]:
    """`n` queries with parameters no queryable may act on."""
    junk = ["abc", "1e9", "0x10", "", "%00", "../../etc/passwd", "nan", "-", "1.5", " 7x"]  # none an integer
    makers = [
        lambda j: Query(f"{keys.train_recent}?from={j}", "recent: from not an integer", ("arbitrator",)),
        lambda j: Query(f"{keys.history('learner')}?epoch=x;upto={j}", "history: upto not an integer", ("learner",)),
        lambda j: Query(f"{supervisor_key(profile, 'logs')}?service=learner;lines={j}", "logs: lines out of range"),
        lambda j: Query(f"{supervisor_key(profile, 'logs')}?service={j}x", "logs: no such service"),
        lambda j: Query(f"{supervisor_key(profile, 'swap')}?service=nobody{j};spec=knn", "swap: no such service"),
        lambda j: Query(f"{supervisor_key(profile, 'swap')}?service=learner;spec=nolearner", "swap: no such learner"),
        lambda j: Query(f"{supervisor_key(profile, 'reboot')}", "an unknown verb"),
        lambda j: Query(f"{supervisor_key(profile, 'ps')}?evil={j}", "ps: an unknown parameter"),
    ]
    return [makers[i % len(makers)](junk[int(rng.integers(len(junk)))]) for i in range(n)]


# --- the run -------------------------------------------------------------------------------------
def newest_statuses(run: LiveRun) -> dict[str, Status]:
    """Each service's newest status (what does not decode, the fuzzer's own, is no status)."""
    return {status.name: status for status in run.messages(Status, f"{run.keys.prefix}/status/**")}


def rejected(run: LiveRun) -> dict[str, int]:
    """Each service's `rejected` counter, from its newest status."""
    return {name: int(status.counters.get("rejected", 0)) for name, status in newest_statuses(run).items()}


def learned(run: LiveRun) -> int:
    status = newest_statuses(run).get("learner")
    return int(status.counters.get("learned", 0)) if status else 0


def arbitrated(run: LiveRun, since: int = 0) -> int:
    """Commands the arbitrator published among those recorded from index `since` (the fuzzer's own
    are recorded too: they do not decode, or name the fuzzer as their source)."""
    return sum(1 for c in run.messages(Command, run.keys.command, since) if c.source != "fuzz")


def command_rate(run: LiveRun, seconds: float) -> float:
    before = len(run.recorded[run.keys.command])
    time.sleep(seconds)
    return arbitrated(run, before) / seconds


def median_latency_ms(run: LiveRun, seconds: float) -> float:
    """Median time from an input's stamp to its command's arrival here, over `seconds`, in ms."""
    lags = []

    def on_command(sample) -> None:  # only appends: decoding waits until the window is over
        lags.append((time.time(), sample.payload.to_bytes()))
    listening = run.session.declare_subscriber(run.keys.command, on_command)
    time.sleep(seconds)
    listening.undeclare()
    commands = ((at, decoded(Command, run.keys.command, raw)) for at, raw in list(lags))
    ms = [1e3 * (at - c.stamp) for at, c in commands if c is not None and c.source != "fuzz"]
    return float(np.median(ms)) if ms else float("nan")


def ask(session, query: Query) -> tuple[int, int]:
    """(replies, error replies) to one query."""
    replies = errors = 0
    for reply in session.get(query.selector, timeout=5.0):
        replies += 1
        if reply.ok is None:
            errors += 1
        else:
            try:
                if not decode(ControlReply, reply.ok.payload.to_bytes(), query.selector).ok:
                    errors += 1
            except ValueError:
                pass
    return replies, errors


def run_fuzz(run_dir: Path, endpoint: str, n_payloads: int = 9000, n_queries: int = 1000, learner: str = "gp",
             seed: int = 0, log=print) -> FuzzResult:
    run_dir.mkdir(parents=True, exist_ok=True)
    profile = run_dir / "faults.toml"
    # the fuzzer plays a peer on the bus, which access control would refuse at the door: security off, so
    # what it sends reaches each service, whose own checks are what this measures
    profile.write_text(mirroring_profile(run_dir, learner, security="off"))
    run = LiveRun(profile, run_dir, endpoint)
    held = run.record(f"{run.keys.prefix}/status/**")
    rng, result = np.random.default_rng(seed), FuzzResult()
    try:
        run.wait_ready()
        run.teach(True)
        time.sleep(4.0)
        rows = run.ps()
        pids = {name: row["pid"] for name, row in rows.items()}
        result.rate_before = command_rate(run, 3.0)
        before, result.learned_before_fuzz = rejected(run), learned(run)
        refused_before = run_ps_refused(run)
        epoch, seq = arbitrator_epoch(run)
        todo = cases(rng, run.keys, run.robot, n_payloads, epoch, seq)
        start, sent_commands = time.monotonic(), len(run.recorded[run.keys.command])
        send_payloads(run, todo, result)
        send_queries(run, queries(rng, run.keys, "faults", n_queries), result)
        elapsed = time.monotonic() - start
        result.rate_during = arbitrated(run, sent_commands) / elapsed
        time.sleep(3.0)  # every status refreshed
        after = rejected(run)
        result.counted = {name: after.get(name, 0) - before.get(name, 0) for name in set(after) | set(before)}
        refused = Counter(run_ps_refused(run))
        refused.subtract(refused_before)
        result.counted["supervisor"] = refused.pop("status", 0)  # statuses it would not keep
        result.supervisor_refused = sum(refused.values())  # verbs it answered with an error
        result.learned_after_fuzz = learned(run)
        rows = run.ps()
        result.restarts = {name: row.get("restarts", 0) for name, row in rows.items()}
        result.pids_kept = {name: row["pid"] for name, row in rows.items()} == pids
        time.sleep(5.0)  # teaching goes on
        result.learned_at_end = learned(run)
        # a ghost: a teaching token with nobody behind it; the loop waits for it a few ticks, then not
        result.latency_ms_before = median_latency_ms(run, 3.0)
        ghost = run.session.liveliness().declare_token(run.keys.teaching("ghost"))
        result.latency_ms_ghost = median_latency_ms(run, 3.0)
        ghost.undeclare()
        run.teach(False)  # and the student, alone, does what it was taught
        off = run.tick()
        time.sleep(3.0)
        result.student_rms_after, _ = student_error(run, off + 3, until_tick=run.tick())
        log(f"fuzz: {sum(result.sent.values())} cases in {elapsed:.1f} s; command rate {result.rate_before:.1f} -> "
            f"{result.rate_during:.1f} Hz; rejections due {dict(result.expected)}, counted {result.counted}; "
            f"student after {result.student_rms_after:.4f} rad; tick latency {result.latency_ms_before:.2f} ms, "
            f"with a ghost teacher {result.latency_ms_ghost:.2f} ms")
    finally:
        held.undeclare()
        run.close()
    return result


def send_payloads(run: LiveRun, todo: list, result: FuzzResult) -> None:
    """Put every case on its key, reliably, counting what each service should reject."""
    publishers = {}
    for i, case in enumerate(todo):
        pub = publishers.get(case.key)
        if pub is None:
            pub = publishers[case.key] = run.session.declare_publisher(
                case.key, congestion_control=zenoh.CongestionControl.BLOCK, reliability=zenoh.Reliability.RELIABLE)
            wait_matching(pub, 3.0)
        pub.put(case.payload)
        result.sent[case.what] += 1
        for service in case.counted_by:
            result.expected[service] += 1
        if i % 200 == 199:
            time.sleep(0.05)  # a stranger's flood, not a denial of service: the loop's rate is measured


def send_queries(run: LiveRun, todo, result: FuzzResult) -> None:
    for query in todo:
        _, errors = ask(run.session, query)
        result.queries += 1
        result.query_errors += errors
        for service in query.counted_by:
            result.expected[service] += 1
        result.sent[f"query: {query.what}"] += 1


def run_ps_refused(run: LiveRun) -> dict:
    """The supervisor's count of verbs it answered with an error."""
    out = subprocess.run([sys.executable, "-m", "services.cli", "--connect", run.endpoint, "ps", "--json"],
                         capture_output=True, text=True, timeout=30)
    return json.loads(out.stdout).get("refused", {}) if out.returncode == 0 else {}


def arbitrator_epoch(run: LiveRun) -> tuple[str, int]:
    for status in newest_statuses(run).values():
        if status.role == "arbitrator":
            return str(status.state.get("epoch", "")), int(status.state.get("seq", 0))
    raise RuntimeError("no arbitrator status yet")
