"""Hot-swap a learner: start the new one warmed from the old, switch the arbitrator, stop the old.

Ticks stay answered because the old learner serves until the arbitrator has switched; pairs stay
whole because the new learner subscribes to the training pairs before it takes the old one's
snapshot, and fills any gap from the arbitrator's recent pairs (see services.boxes.learner).
"""
from __future__ import annotations

import dataclasses
import logging
import time
from pathlib import Path

from bus_schema import ControlReply
from services.supervisor.profile import ServiceSpec, swapped_from

log = logging.getLogger("dogged.supervisor")


def parse_learner_spec(text: str) -> tuple[str, list[str]]:
    """'sogp' or 'sogp:capacity=200,noise=0.01' -> ('sogp', ['--param', 'capacity=200', ...])."""
    name, _, rest = text.partition(":")
    params = []
    for item in filter(None, rest.split(",")):
        if "=" not in item:
            raise ValueError(f"learner spec {text!r}: {item!r} is not name=value")
        params += ["--param", item]
    if not name:
        raise ValueError("learner spec is empty; expected e.g. 'sogp' or 'lwpr:init_d=25'")
    from services.learners import LEARNERS
    if name not in LEARNERS:  # refused at once, not after a learner that cannot start has timed out
        raise ValueError(f"no learner {name!r}; learners: {', '.join(sorted(LEARNERS))}")
    return name, params


def _kept_args(args: tuple[str, ...]) -> list[str]:
    """The old learner's flags minus what defines the learner itself."""
    out, skip = [], False
    for arg in args:
        if skip:
            skip = False
        elif arg in ("--learner", "--param", "--warm-from"):
            skip = True
        else:
            out.append(arg)
    return out


def _wait(sup, session, condition, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        item = sup.inbox.get(0.05)
        while item is not None:
            if item[0] == "control":  # another verb during a swap: answer it later, in order
                sup.deferred.append(item)
            else:
                sup.on_event(item, session)
            item = sup.inbox.get_nowait()
        sup.watch()
        if condition():
            return True
    return False


def _set_aside_stale_log(args: tuple[str, ...], name: str) -> None:
    """A pair log under the new learner's name is an earlier run's (swap numbers start again with each
    `dogged up`): replayed, it would stand in for warming from the learner being replaced. It is kept,
    renamed, not deleted."""
    if "--state-dir" not in args:
        return
    log_file = Path(args[args.index("--state-dir") + 1]) / f"{name}.pairs"
    if log_file.exists():
        aside = log_file.with_name(f"{log_file.name}.{time.strftime('%Y%m%d-%H%M%S')}.earlier")
        log_file.rename(aside)
        log.warning("an earlier run's %s set aside as %s before the swap", log_file, aside.name)


def swap_learner(sup, session, service: str, spec_text: str) -> ControlReply:
    from services.supervisor.supervisor import select_learner
    learners = [p for p in sup.procs.values() if p.spec.box == "learner" and p.state == "ready"]
    old = sup.procs.get(service) if service else (learners[0] if len(learners) == 1 else None)
    if old is None or old.spec.box != "learner":
        names = ", ".join(p.spec.name for p in learners) or "none"
        return ControlReply(False, f"say which learner to swap (--service); ready learners: {names}", {})
    try:
        learner, params = parse_learner_spec(spec_text)
    except ValueError as err:
        return ControlReply(False, str(err), {})
    sup.swap_count += 1
    base = swapped_from(old.spec.name)
    new_name = f"{base}-s{sup.swap_count}"
    args = ("--learner", learner, *params, "--warm-from", old.spec.name, *_kept_args(old.spec.args))
    spec = dataclasses.replace(old.spec, name=new_name, args=args)
    _set_aside_stale_log(sup.profile.service_args(spec), new_name)
    started = time.monotonic()
    new = sup.add(spec)
    if not _wait(sup, session, lambda: new.state == "ready", spec.ready_timeout_s):
        new.stop()
        del sup.procs[new_name]
        return ControlReply(False, f"{new_name} did not become ready in {spec.ready_timeout_s:.0f} s; "
                                   f"{old.spec.name} still serves (see dogged logs {new_name})", {})
    warm_s = time.monotonic() - started
    select_learner(session, spec.instance, new_name)
    switched = _wait(sup, session, lambda: _arbitrator_reports(sup, new_name), 10.0)
    if not switched:
        return ControlReply(False, f"the arbitrator did not confirm {new_name}; both learners keep running", {})
    old.stop()
    del sup.procs[old.spec.name]
    return ControlReply(True, f"{new_name} ({learner}) serves in place of {old.spec.name} "
                              f"(warm in {warm_s:.1f} s)", {"new": new_name, "old": old.spec.name})


def _arbitrator_reports(sup, learner: str) -> bool:
    return any(s.get("state", {}).get("learner") == learner
               for member, s in sup.status.items() if member.startswith("arbitrator/"))
