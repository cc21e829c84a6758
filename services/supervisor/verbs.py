"""The supervisor's verbs (`dogged ps|logs|swap|down`, queries to dogged/supervisor/<profile>/<verb>):
each answered with a ControlReply; during a hot-swap another swap waits its turn, the rest are answered
at once."""
from __future__ import annotations

import itertools
import logging
import math
import time

import zenoh

from bus_schema import ControlReply, encode
from services.bus.publishers import HOST
from services.placement import cpus_of
from services.supervisor.swap import swap_learner

log = logging.getLogger("dogged.supervisor")
# the supervisor's verbs and the parameters each takes; anything else is refused with an answer
VERBS = {"ps": set(), "logs": {"service", "lines"}, "swap": {"service", "spec"}, "down": set()}
MAX_LOG_LINES = 10_000
REMOTE_FORGOTTEN_S = 5.0  # a service not ours whose status stopped coming this long ago is left out of `ps`
MAX_DEFERRED = 64  # verbs held while a swap runs; beyond, each is answered at once that a swap is under way


class Verbs:
    """The verbs of services.supervisor.supervisor.Supervisor, which holds the state they read: procs,
    waiting, started, status, refused, deferred, swapping, stopping, inbox, profile."""

    def on_control(self, verb: str, query: zenoh.Query, session) -> None:
        try:
            reply = self.answer(verb, query.parameters, session)
        except Exception as err:  # noqa: BLE001 - a verb that goes wrong is an answer, never the end
            log.exception("%s failed", verb)
            reply = ControlReply(False, f"{verb} failed: {type(err).__name__}: {err}", {})
        if not reply.ok:
            self.refused[verb if verb in VERBS else "unknown"] += 1
        query.reply(str(query.key_expr), encode(reply))

    def answer(self, verb: str, params, session) -> ControlReply:
        unknown = sorted({name for name, _ in params} - VERBS.get(verb, set()))
        if verb not in VERBS:
            return ControlReply(False, f"no verb {verb[:64]!r}; verbs: {', '.join(VERBS)}", {})
        if unknown:
            return ControlReply(False, f"{verb}: unknown parameter(s) {', '.join(unknown)[:200]}", {})
        if self.swapping and verb not in ANSWERED_DURING_SWAP:
            return ControlReply(False, f"{verb}: a hot-swap is under way and {MAX_DEFERRED} verbs wait for it; "
                                       "ask again after it", {})
        if verb == "ps":
            return ControlReply(True, "", {"profile": self.profile.name, "services": self.ps(),
                                           "refused": dict(self.refused)})
        if verb == "logs":
            lines = params.get("lines", "50")
            if not (lines.isdigit() and 1 <= int(lines) <= MAX_LOG_LINES):
                return ControlReply(False, f"logs: lines must be an integer 1..{MAX_LOG_LINES}, got {lines[:32]!r}", {})
            return self.logs(params.get("service", ""), int(lines))
        if verb == "swap":
            return self.swap(session, params.get("service", ""), params.get("spec", ""))
        self.stopping = True
        return ControlReply(True, f"stopping profile {self.profile.name}", {})

    def ps(self) -> list[dict]:
        """Its own services, then every other service whose status came in the last few seconds
        (a teacher on another machine, another profile's share of the deployment), with its host."""
        rows = []
        for proc in self.procs.values():
            row = proc.describe()
            status = self.status_of(proc.spec)
            row.update(rates=status.get("rates", {}), host=status.get("host", HOST), ticks=tick_counters(status),
                       instance=proc.spec.instance)
            if self.profile.placement is not None and (cpus := cpus_of(proc.pid)):
                row["cpus"] = cpus  # where it runs (services.placement): read from the kernel, not its word
            error = status.get("state", {}).get("error")
            if error and isinstance(error, str) and "why" not in row:  # a service says what it cannot do
                row["why"] = error[:200]
            rows.append(row)
        for spec in self.waiting:
            why = "after " + ", ".join(f"{a} ({self.procs[a].state})" if a in self.procs else a for a in spec.after)
            rows.append(not_running_row(spec.name, spec.box, "waiting", why=why, instance=spec.instance))
        now = time.monotonic()
        for key, status in sorted(self.status.items()):
            if key not in self.started and now - status["seen"] < REMOTE_FORGOTTEN_S:
                role, name = key.split("/", 1)
                rows.append(not_running_row(name, role, "remote", pid=status["pid"], rates=status["rates"],
                                            host=status["host"], ticks=tick_counters(status),
                                            instance=status["instance"]))
        return rows

    def logs(self, service: str, lines: int) -> ControlReply:
        if service not in self.procs:
            return ControlReply(False, f"no service {service!r}; services: {', '.join(self.procs)}", {})
        tail = list(self.procs[service].tail)[-lines:]
        return ControlReply(True, "\n".join(tail), {"path": str(self.procs[service].log_path)})

    # --- hot-swap ---------------------------------------------------------------------------
    def swap(self, session, service: str, spec_text: str) -> ControlReply:
        self.swapping = True
        try:
            return swap_learner(self, session, service, spec_text)
        finally:
            self.swapping = False

    def handle_events(self, session) -> None:
        """What came in for up to 50 ms; during a swap, another swap waits (answered after it, in order);
        `ps` and `logs` are answered at once, and `down` honoured at once: the swap then gives up and its
        new learner is stopped."""
        first = [self.deferred.pop(0)] if self.deferred and not self.swapping else []
        for item in itertools.chain(first, self.inbox.drain(0.0 if first else 0.05)):
            if self.swapping and held_during_swap(item) and len(self.deferred) < MAX_DEFERRED:
                self.deferred.append(item)
            else:  # (a verb past MAX_DEFERRED during a swap is answered: busy)
                self.on_event(item, session)

    def answer_deferred(self) -> None:
        """Verbs still held when the profile stops are told so, not left to time out."""
        for _, key, query, _ in self.deferred:
            verb = key.rsplit("/", 1)[-1]
            query.reply(str(query.key_expr), encode(ControlReply(False, f"{verb}: the profile is stopping", {})))
        self.deferred.clear()


ANSWERED_DURING_SWAP = ("down", "ps", "logs")  # down stops it; ps and logs only read


def held_during_swap(item: tuple) -> bool:
    """Whether a bus event waits for a swap to end: a verb that would change what the swap changes
    (another swap); `down` is honoured at once, and `ps` and `logs` only read, so they are answered
    at once too (held, the CLI gave up after its 5 s while a long swap ran)."""
    tag, key = item[0], item[1]
    return tag == "control" and key.rsplit("/", 1)[-1] not in ANSWERED_DURING_SWAP


def not_running_row(name: str, box: str, state: str, **fields) -> dict:
    """A `ps` row for a service this supervisor does not run: one still waiting, or another machine's."""
    return {"name": name, "box": box, "pid": 0, "state": state, "restarts": 0, "uptime_s": 0.0, "exit": "",
            "rates": {}, "host": HOST, **fields}


def tick_counters(status: dict) -> dict:
    """A platform's lost and stale ticks, as its status counts them; an arbitrator's ticks decided without the
    learner's proposal (past the deadline, the learner not waited for, or none alive), their share in %, and
    how long it waits for a tick's proposals."""
    counters = status.get("counters", {})
    out = {k: counters[k] for k in ("lost_ticks", "stale_commands", "without_learner") if k in counters}
    deadline = status.get("state", {}).get("deadline_ms")  # state is free-form: only a finite number is shown
    if isinstance(deadline, (int, float)) and not isinstance(deadline, bool) and math.isfinite(deadline):
        out["deadline_ms"] = deadline
    if "without_learner" in out and counters.get("commands"):
        out["without_learner_pct"] = round(100 * out["without_learner"] / counters["commands"], 2)
    return out
