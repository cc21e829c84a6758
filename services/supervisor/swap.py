"""Hot-swap a learner: start the new one warmed from the old, switch the arbitrator, stop the old.

Ticks stay answered because the old learner serves until the arbitrator has switched; pairs stay
whole because the new learner subscribes to the training pairs before it takes the old one's
snapshot, and fills any gap from the arbitrator's recent pairs (see services.boxes.learner).
"""
from __future__ import annotations

import argparse
import dataclasses
import logging
import time

from bus_schema import ControlReply, InstanceKeys, SelectLearner, encode
from services.boxes import learner as learner_box
from services.bus.publishers import lossless_publisher
from services.learners import parse_learner_spec
from services.supervisor.pair_logs import set_aside_stale_log

log = logging.getLogger("dogged.supervisor")


LEARNER_DESTS = ("learner", "param", "warm_from")  # what defines a learner, not where it runs


def _kept_args(args: tuple[str, ...]) -> list[str]:
    """The old learner's arguments minus what defines the learner itself, however spelled (`--param x`,
    `--param=x`, `--par x`): a parser of the learner box's own flags for those takes them out."""
    defining = argparse.ArgumentParser(add_help=False)
    for action in learner_box.arg_parser()._actions:  # (argparse lists a parser's flags nowhere public)
        if action.dest in LEARNER_DESTS:
            defining.add_argument(*action.option_strings, dest=action.dest, action="append")
    _, kept = defining.parse_known_args(list(args))
    return kept


def swap_learner(sup, session, service: str, spec_text: str) -> ControlReply:
    """Swaps learner `service` (or the only ready one) for `spec_text`, waiting in the supervisor's
    event loop (sup.pump) so that everything else goes on meanwhile."""
    learners = sup.ready_learners()
    old = sup.procs.get(service) if service else (learners[0] if len(learners) == 1 else None)
    if old is None or old.spec.box != "learner":
        names = ", ".join(p.spec.name for p in learners) or "none"
        return ControlReply(False, f"say which learner to swap (--service); ready learners: {names}", {})
    try:
        learner, params = parse_learner_spec(spec_text)
    except ValueError as err:
        return ControlReply(False, str(err), {})
    sup.swap_count += 1
    stands_for = old.spec.stands_for or old.spec.name  # the profile's service, whatever its name
    new_name = f"{stands_for}-s{sup.swap_count}"
    args = ("--learner", learner, *params, "--warm-from", old.spec.name, *_kept_args(old.spec.args))
    spec = dataclasses.replace(old.spec, name=new_name, args=args, stands_for=stands_for)
    set_aside_stale_log(sup.profile.state_dir_of(spec), new_name)
    started = time.monotonic()
    new = sup.add(spec)
    sup.pump(session, lambda: new.state != "starting", spec.ready_timeout_s + 1.0)
    if new.state != "ready":
        sup.retire(new_name)
        why = "the profile is stopping" if sup.stopping else (
            f"it did not become ready in {spec.ready_timeout_s:g} s" if new.last_exit in (None, "not ready")
            else f"it exited with {new.last_exit}")
        return ControlReply(False, f"{new_name} does not serve: {why}; {old.spec.name} still serves "
                                   f"(see dogged logs {new_name})", {})
    behind = _catch_up(sup, session, spec)
    if behind:
        sup.retire(new_name)
        return ControlReply(False, f"{new_name} does not serve: {behind}; {old.spec.name} still serves "
                                   f"(see dogged logs {new_name})", {})
    warm_s = time.monotonic() - started
    if not _select(sup, session, spec.instance, new_name):
        return ControlReply(False, f"the arbitrator did not confirm {new_name} (told {SELECT_TRIES} times); "
                                   "both learners keep running", {})
    sup.retire(old.spec.name)
    sup.pump(session, lambda: "warmed" in sup.status_of(spec).get("counters", {}), 3.0)
    return ControlReply(True, f"{new_name} ({spec_text}) serves in place of {old.spec.name}, "
                              f"{_how_warmed(sup.status_of(spec))} in {warm_s:.1f} s",
                        {"new": new_name, "old": old.spec.name})


# the selection is said again until the arbitrator's status confirms it: a put can be lost (a fresh clone's CI, the
# fast and slow tiers beside: "the arbitrator did not confirm learner-s1" after one put and 10 s)
SELECT_TRIES, SELECT_WAIT_S = 4, 5.0


def _select(sup, session, instance: str, new_name: str) -> bool:
    """Tells the instance's arbitrator which learner to listen to, again until its status says it does; every wait in
    the supervisor's event loop (sup.pump), a subscriber matched before each put."""
    pub = lossless_publisher(session, InstanceKeys(instance).select_learner)
    try:
        for _ in range(SELECT_TRIES):
            sup.pump(session, lambda: pub.matching_status.matching, SELECT_WAIT_S)
            pub.put(encode(SelectLearner(new_name)))
            if sup.pump(session, lambda: sup.reports("arbitrator", "learner", new_name), SELECT_WAIT_S):
                return True
            if sup.stopping:
                return False
        return False
    finally:
        pub.undeclare()


# a new learner learns the old one's history between answers (services.boxes.learner): the swap selects it once
# it has caught up, waiting as long as it learns, and no longer than this without a pair learned
CATCH_UP_STALL_S = 30.0


def _progress(status: dict) -> tuple[int, int] | None:
    """(the seq of the last pair learned, pairs yet to learn) from a learner's status, None until it says both."""
    counters = status.get("counters", {})
    seq, backlog = counters.get("seq"), counters.get("backlog")
    if not all(isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in (seq, backlog)):
        return None
    return seq - backlog, backlog


def _catch_up(sup, session, spec) -> str:
    """Waits until the new learner's status says it has learned all it was given: '' then, else why not. Progress
    is pairs learned, not a shrinking backlog: taught meanwhile faster than it learns as offline (a GP's fits in
    its own thread), the backlog grows while the learner gains on the history (mirroring's swap to a GP during a
    lesson: "learned nothing of its last 24115 pairs in 30 s", twice, where it had learned 9,000)."""
    best = None
    while True:
        def gains(best=best) -> bool:
            now = _progress(sup.status_of(spec))
            return now is not None and (now[1] == 0 or best is None or now[0] > best)
        gained = sup.pump(session, gains, CATCH_UP_STALL_S)
        if sup.stopping:
            return "the profile is stopping"
        now = _progress(sup.status_of(spec))
        if not gained or now is None:
            return (f"it did not say its backlog within {CATCH_UP_STALL_S:g} s" if best is None else
                    f"it learned no pair in {CATCH_UP_STALL_S:g} s ({now[1] if now else '?'} pairs behind)")
        if now[1] == 0:
            return ""
        best = now[0]


def _how_warmed(status: dict) -> str:
    counters = status.get("counters", {})
    if counters.get("warm_failed"):
        return "started cold: the old one's snapshot or history did not come (see its log)"
    if counters.get("warmed_by_snapshot"):
        return "restored from the old one's snapshot"
    if "warmed" in counters:
        return f"trained on its {counters['warmed']} pairs"
    return "warmed (its status did not say how)"
