"""The supervisor's policies on real OS processes, its bus faked: start order, restart policy and
backoff, max_restarts, ready_timeout_s at `up`, hot-swap's failure paths, swap names and flags.

A service is "ready" here when the test adds its liveliness key to `sup.alive`, as the bus would."""
import logging
import sys
import time

import pytest
import zenoh

from bus_schema import ControlReply, decode, supervisor_key
from services.supervisor import process
from services.supervisor.profile import Profile, ServiceSpec
from services.supervisor.supervisor import Supervisor
from services.supervisor.verbs import MAX_DEFERRED
from services.supervisor.swap import _kept_args, swap_learner

pytestmark = pytest.mark.live

SLEEPS = [sys.executable, "-c", "import time; time.sleep(60)"]


def exits(code: int) -> list[str]:
    return [sys.executable, "-c", f"import sys; sys.exit({code})"]


class FakeCommands(Supervisor):
    """Each service runs the command the test gives for its name (SLEEPS by default), not a box."""

    def __init__(self, tmp_path, *specs: ServiceSpec, commands=None):
        profile = Profile("policy", tmp_path / "policy.toml", "tcp/127.0.0.1:9", tmp_path / "logs", specs)
        super().__init__(profile, echo=False)
        self.commands = commands or {}
        self.waiting = list(specs)

    def command_for(self, spec):
        return self.commands.get(spec.name, SLEEPS)

    def ready(self, name: str) -> None:
        self.alive.add(self.procs[name].ready_key)

    def turn(self, until, timeout: float = 10.0) -> bool:
        return self.pump(None, until, timeout)

    def stop_all(self):
        for proc in self.procs.values():
            proc.stop(1.0)


def spec(name: str, **kw) -> ServiceSpec:
    return ServiceSpec(name, kw.pop("box", "platform"), "main", **kw)


def test_services_start_in_the_order_after_says(tmp_path):
    sup = FakeCommands(tmp_path, spec("c", after=("b",)), spec("a"), spec("b", after=("a",)))
    try:
        sup.start_due()
        assert list(sup.procs) == ["a"]
        assert {r["name"]: r["state"] for r in sup.ps()} == {"a": "starting", "c": "waiting", "b": "waiting"}
        sup.ready("a")
        assert sup.turn(lambda: "b" in sup.procs)
        assert "c" not in sup.procs, "c comes after b, which is not ready yet"
        sup.ready("b")
        assert sup.turn(lambda: "c" in sup.procs)
        assert [sup.procs[n].started_at for n in "abc"] == sorted(sup.procs[n].started_at for n in "abc")
    finally:
        sup.stop_all()


def test_on_failure_restarts_with_doubling_backoff_then_fails_after_max_restarts(tmp_path):
    sup = FakeCommands(tmp_path, spec("flaky", restart="on-failure", max_restarts=2, backoff_s=0.2),
                       commands={"flaky": exits(3)})
    delays = []
    sup.start_due()
    proc = sup.procs["flaky"]
    while proc.state != "failed":
        assert sup.turn(lambda: proc.state in ("backoff", "failed"), 10.0)
        if proc.state == "backoff":
            delays.append(round(proc.restart_at - proc.died_at, 1))
            assert sup.turn(lambda: proc.state != "backoff", 5.0)
    assert delays == [0.2, 0.4]
    assert proc.restarts == 2 and proc.last_exit == 3


def test_a_service_that_ran_a_while_before_it_died_is_restarted_past_max_restarts(tmp_path, monkeypatch):
    """(a robot run all day, a service killed now and then: after its max_restarts-th kill it stayed down
    for good, and each restart waited longer than the last, however long it had run in between: issue 31)"""
    monkeypatch.setattr(process, "HEALTHY_S", 0.3)
    sup = FakeCommands(tmp_path, spec("long", restart="on-failure", max_restarts=1, backoff_s=0.05),
                       commands={"long": [sys.executable, "-c", "import sys, time; time.sleep(0.5); sys.exit(3)"]})
    sup.start_due()
    proc = sup.procs["long"]
    delays = []
    while len(delays) < 3:
        assert sup.turn(lambda: proc.state in ("backoff", "failed"), 10.0) and proc.state == "backoff", proc.state
        delays.append(round(proc.restart_at - proc.died_at, 2))
        assert sup.turn(lambda: proc.state != "backoff", 5.0)
    assert delays == [0.05, 0.05, 0.05] and proc.restarts == 3 and proc.describe()["restarts"] == 3
    sup.stop_all()


def test_restart_policies_on_a_clean_exit(tmp_path):
    sup = FakeCommands(tmp_path, spec("never", restart="never"), spec("on-failure", restart="on-failure"),
                       spec("always", restart="always", backoff_s=0.1, max_restarts=1),
                       commands={"never": exits(0), "on-failure": exits(0), "always": exits(0)})
    assert sup.turn(lambda: {p.state for p in sup.procs.values()} <= {"exited", "failed"} and len(sup.procs) == 3)
    assert {n: (p.state, p.restarts) for n, p in sup.procs.items()} == {
        "never": ("exited", 0), "on-failure": ("exited", 0), "always": ("exited", 1)}


def test_a_service_not_ready_in_time_is_stopped_and_what_waits_for_it_is_told(tmp_path, caplog):
    sup = FakeCommands(tmp_path, spec("slow", ready_timeout_s=0.5, max_restarts=0), spec("next", after=("slow",)))
    caplog.set_level(logging.INFO, "dogged.supervisor")
    sup.start_due()
    slow = sup.procs["slow"]
    pid = slow.pid
    assert sup.turn(lambda: slow.state == "failed", 10.0), slow.state
    assert slow.last_exit == "not ready" and slow.pid is None and slow.proc.poll() is not None, pid
    sup.turn(lambda: False, 0.3)
    rows = {r["name"]: r for r in sup.ps()}
    assert rows["next"]["state"] == "waiting" and rows["next"]["why"] == "after slow (failed)"
    errors = [r.getMessage() for r in caplog.records if r.levelno == logging.ERROR]
    assert any("slow did not become ready within 0.5 s" in e and "next wait for it" in e for e in errors), errors
    assert sum("next will not start: it comes after slow, which failed" in e for e in errors) == 1, errors


def test_a_service_not_ready_in_time_is_restarted_while_restarts_remain(tmp_path):
    sup = FakeCommands(tmp_path, spec("slow", ready_timeout_s=0.3, max_restarts=1, backoff_s=0.1))
    sup.start_due()
    slow = sup.procs["slow"]
    assert sup.turn(lambda: slow.restarts == 1 and slow.state == "starting", 10.0)
    sup.ready("slow")
    assert sup.turn(lambda: slow.state == "ready", 5.0)
    sup.stop_all()


def learner(name="learner", **kw) -> ServiceSpec:
    return spec(name, box="learner", args=("--learner", "knn", "--param=k=5", "--seed", "5"), **kw)


def ready_learner(tmp_path, commands, **kw) -> FakeCommands:
    sup = FakeCommands(tmp_path, learner(**kw), commands=commands)
    sup.start_due()
    sup.ready("learner")
    assert sup.turn(lambda: sup.procs["learner"].state == "ready")
    return sup


def test_swap_refuses_an_unknown_learner_or_service_and_starts_nothing(tmp_path):
    sup = ready_learner(tmp_path, {})
    try:
        reply = swap_learner(sup, None, "learner", "nosuch")
        assert not reply.ok and "no learner 'nosuch'" in reply.text
        reply = swap_learner(sup, None, "other", "knn")
        assert not reply.ok and "ready learners: learner" in reply.text
        assert list(sup.procs) == ["learner"]
    finally:
        sup.stop_all()


def test_a_swap_whose_learner_exits_leaves_the_old_one_serving(tmp_path):
    sup = ready_learner(tmp_path, {"learner-s1": exits(2)})
    try:
        reply = swap_learner(sup, None, "learner", "knn:k=3")
        assert not reply.ok and "learner-s1 does not serve: it exited with 2" in reply.text, reply.text
        assert list(sup.procs) == ["learner"] and sup.procs["learner"].state == "ready"
    finally:
        sup.stop_all()


def test_a_swap_whose_learner_is_never_ready_gives_up_at_its_ready_timeout(tmp_path):
    sup = ready_learner(tmp_path, {}, ready_timeout_s=1.0)
    try:
        started = time.monotonic()
        reply = swap_learner(sup, None, "learner", "knn")
        assert not reply.ok and "did not become ready in 1 s" in reply.text, reply.text
        assert 1.0 <= time.monotonic() - started < 4.0
        assert list(sup.procs) == ["learner"] and sup.procs["learner"].state == "ready"
    finally:
        sup.stop_all()


def test_a_swap_stops_waiting_when_the_profile_stops(tmp_path):
    class StopsSoon:  # Ctrl-C half a second into the swap
        at = time.monotonic() + 0.5

        def __bool__(self):
            return time.monotonic() > self.at

    sup = ready_learner(tmp_path, {})
    sup.stop_flag = StopsSoon()
    try:
        started = time.monotonic()
        reply = swap_learner(sup, None, "learner", "knn")
        assert not reply.ok and "the profile is stopping" in reply.text and time.monotonic() - started < 5.0
        assert sup.stopping and "learner-s1" not in sup.procs
    finally:
        sup.stop_all()


class FakeQuery:
    def __init__(self, verb: str, parameters: str = ""):
        self.key_expr, self.parameters = supervisor_key("policy", verb), zenoh.Parameters(parameters)
        self.replies = []

    def reply(self, key, payload):
        self.replies.append(decode(ControlReply, payload, key))


def test_a_swap_that_arrives_during_a_swap_waits_for_it_but_down_does_not(tmp_path):
    """`down` waited with the other verbs: the CLI gave up after 5 s while the profile stopped up to a
    minute later. Now the swap gives up at once, its new learner stopped, and a second swap is told why."""
    sup = ready_learner(tmp_path, {}, ready_timeout_s=15.0)  # the new learner is never ready
    second, down = FakeQuery("swap"), FakeQuery("down")
    for query in (second, down):
        sup.inbox.put(("control", str(query.key_expr), query, None))
    try:
        started = time.monotonic()
        reply = sup.swap(None, "learner", "knn")
        assert time.monotonic() - started < 5.0, f"down waited for the swap: {reply.text}"
        assert down.replies and down.replies[0].ok and "stopping profile" in down.replies[0].text
        assert not reply.ok and "the profile is stopping" in reply.text, reply.text
        assert "learner-s1" not in sup.procs and sup.stopping
        assert second.replies == [] and len(sup.deferred) == 1, "a second swap waits for the first"
        sup.answer_deferred()
        assert not second.replies[0].ok and "the profile is stopping" in second.replies[0].text
    finally:
        sup.stop_all()


def test_ps_and_logs_are_answered_at_once_during_a_swap(tmp_path):
    """They waited for the swap to end, and the CLI gave up after 5 s while a long swap warmed its
    learner ("did not answer"); they only read, so they are answered while the swap runs."""
    sup = ready_learner(tmp_path, {})
    ps, logs = FakeQuery("ps"), FakeQuery("logs", "service=learner")
    for query in (ps, logs):
        sup.inbox.put(("control", str(query.key_expr), query, None))
    try:
        sup.swapping = True
        sup.turn(lambda: bool(ps.replies and logs.replies), 2.0)
        assert ps.replies and ps.replies[0].ok and "learner" in {row["name"] for row in ps.replies[0].data["services"]}
        assert logs.replies and logs.replies[0].ok, logs.replies
        assert sup.deferred == []
    finally:
        sup.swapping = False
        sup.stop_all()


def test_a_flood_of_verbs_during_a_swap_is_held_up_to_a_bound_and_the_rest_answered_busy(tmp_path):
    """Verbs held during a swap were unbounded: a stranger's flood of well-formed queries (any local
    process may ask on an unsecured profile) grew the list for as long as the swap ran."""
    sup = ready_learner(tmp_path, {})
    flood = [FakeQuery("swap") for _ in range(MAX_DEFERRED + 36)]
    for query in flood:
        sup.inbox.put(("control", str(query.key_expr), query, None))
    try:
        sup.swapping = True
        sup.turn(lambda: False, 0.3)
        busy = [q.replies[0] for q in flood if q.replies]
        assert len(sup.deferred) == MAX_DEFERRED and len(busy) == 36 and sup.refused["swap"] == 36
        assert all(not r.ok and "a hot-swap is under way" in r.text for r in busy)
        sup.swapping = False
        sup.turn(lambda: not sup.deferred, 5.0)
        held = [q.replies[-1] for q in flood[:MAX_DEFERRED] if q.replies]
        assert len(held) == MAX_DEFERRED and not any("a hot-swap is under way" in r.text for r in held), \
            "the held ones answered after it"
    finally:
        sup.stop_all()


def test_a_swapped_learner_keeps_the_profile_name_and_drops_every_learner_flag(tmp_path):
    """Names with '-s' in them (fast-sogp) kept their certificate only up to '-s'; `--param=x` leaked."""
    sup = ready_learner(tmp_path, {"fast-sogp-s1": exits(2)})
    sup.procs["fast-sogp"] = sup.procs.pop("learner")
    sup.procs["fast-sogp"].spec = learner("fast-sogp")
    try:
        swap_learner(sup, None, "fast-sogp", "knn")
        started = [s for s in sup.started if "fast-sogp-s" in s]
        assert started == ["learner/fast-sogp-s1"]
        assert sup.profile.identity(learner("fast-sogp")) == "learner.fast-sogp"
        swapped = learner("fast-sogp-s2", stands_for="fast-sogp")
        assert sup.profile.identity(swapped) == "learner.fast-sogp"
        assert _kept_args(("--learner", "knn", "--param=k=5", "--param", "x=1", "--warm-from=a", "--seed", "5")) == [
            "--seed", "5"]
        # spelled as argparse also reads them: abbreviated, with '=' (they leaked into the new learner)
        assert _kept_args(("--learn=knn", "--par", "k=5", "--warm", "a", "--state-dir=/s")) == ["--state-dir=/s"]
    finally:
        sup.stop_all()
