"""`dogged up`: start a router and every service of a profile, watch, restart, hot-swap, stop.

With `--join ENDPOINT` (the profile's share of a deployment whose router runs on another machine)
its router links to that one: the services here talk among themselves on this machine. The
supervisor is a Zenoh client of its router: readiness is a service's liveliness token,
`dogged ps|down|logs|swap` are queries to dogged/supervisor/<profile>/<verb>.
"""
from __future__ import annotations

import collections
import logging
import math
import os
import secrets
import sys
import time
from dataclasses import replace

import zenoh

from bus_schema import (EVERY_ALIVE, EVERY_STATUS, InstanceKeys, Status, check_name, decode, router_token,
                        supervisor_key, supervisor_token)
from services.bus.config import zenoh_config
from services.bus.inbox import Inbox
from services.bus.lifecycle import StopFlag
from services.boxes.router import CANNOT_LISTEN, ROUTING
from services.own_identities import PAGE_TOKEN_ENV, NotPrivate, announce, withdraw
from services.placement import move_process
from services.realtime import hold_low_latency
from services.refusals import Refusals
from services.security import ROSTER_ENV, identities_in
from services.supervisor.pair_logs import adopt_successor_log
from services.supervisor.process import ManagedProcess
from services.supervisor.profile import Profile, ServiceSpec
from services.supervisor.verbs import Verbs

log = logging.getLogger("dogged.supervisor")
MAX_REMOTE = 64  # services not ours kept and listed (the freshest): forged statuses under many names bloat nothing
ROUTER_START_S = 15.0  # the profile's router says it listens within this, or `up` fails saying why
SWITCH_OFF_BEFORE_DEATH = 1.0  # seconds: a teaching token that vanished this soon before its process died went with it


def box_command(box: str, *args: str) -> list[str]:
    return [sys.executable, "-m", "services.cli", "run", box, *args]


class Supervisor(Verbs):
    def __init__(self, profile: Profile, echo: bool = True):
        self.profile, self.echo = profile, echo
        self.procs: dict[str, ManagedProcess] = {}
        self.alive: set[str] = set()
        self.status: dict[str, dict] = {}          # "<role>/<name>" -> latest status
        self.inbox = Inbox()
        self.stopping = False
        self.swap_count = 0
        self.deferred: list = []                   # verbs that arrived during a swap
        self.teaching: dict[str, tuple] = {}       # teacher service -> (its switch, since when)
        self.refused: collections.Counter = collections.Counter()  # verbs answered with an error; bad statuses
        self.started: set[str] = set()             # "<role>/<name>" of every service this supervisor ran
        self.waiting: list[ServiceSpec] = []       # started in order once what they come `after` is ready
        self.blocked: set[str] = set()             # waiting services told they cannot start (what they await failed)
        self.stop_flag: StopFlag | None = None     # Ctrl-C or SIGTERM, while run() runs
        self.swapping = False                      # a swap is under way: other verbs wait their turn
        self.up_since, self.announced = time.monotonic(), False
        self.page_token = secrets.token_urlsafe(18)  # the pages' (PAGE_TOKEN_ENV), for as long as this runs
        # the identities access control knows, read once: every process started, restarted or swapped in
        # enforces this same roster; a certificate made later is refused until the profile restarts
        self.roster = identities_in(profile.security) if profile.security is not None else []

    # --- processes --------------------------------------------------------------------------
    def command_for(self, spec: ServiceSpec) -> list[str]:
        return box_command(spec.box, "--instance", spec.instance, "--name", spec.name,
                           "--connect", self.profile.router, *self.profile.service_args(spec))

    def secured(self, spec: ServiceSpec, identity: str) -> ServiceSpec:
        """The spec with its identity in its environment: that identity's folder only (no other key), and
        the roster read at `up`."""
        if self.profile.security is None:
            return spec
        env = {**spec.env, "DOGGED_SECURITY": str(self.profile.security / identity), "DOGGED_IDENTITY": identity,
               ROSTER_ENV: ",".join(self.roster)}
        return replace(spec, env=env)

    def process(self, spec: ServiceSpec, command: list[str]) -> ManagedProcess:
        """A process to manage, told its CPUs; under security its log is read for what its access control
        refused."""
        if self.profile.placement is not None:
            spec = replace(spec, env={**spec.env, **self.profile.placement.env_for(spec.box)})
        proc = ManagedProcess(spec, command, self.profile.log_dir, self.echo)
        if self.profile.security is not None:
            proc.refusals = Refusals(self.roster, spec.name, log)
        return proc

    def add(self, spec: ServiceSpec, command: list[str] | None = None) -> ManagedProcess:
        spec = self.secured(spec, self.profile.identity(spec))
        if spec.box == "ui":  # restarted, it asks the same token: a page a person has open reconnects
            spec = replace(spec, env={**spec.env, PAGE_TOKEN_ENV: self.page_token})
        proc = self.process(spec, command or self.command_for(spec))
        proc.ready_key = InstanceKeys(spec.instance).alive(spec.role, spec.name)
        self.procs[spec.name] = proc
        self.started.add(f"{spec.role}/{spec.name}")
        proc.start()
        return proc

    def watch(self) -> None:
        now = time.monotonic()
        for proc in list(self.procs.values()):
            code = proc.poll()
            if code is not None and proc.state not in ("backoff", "exited", "failed"):
                proc.died_at = now
            if code is not None and not self.stopping:
                if proc.should_restart(code):
                    proc.schedule_restart()
                else:
                    proc.state = "exited" if code == 0 else "failed"
            if proc.state == "backoff" and now >= proc.restart_at and not self.stopping:
                if proc.spec.box == "demonstrator":
                    proc.command = self.restart_command(proc)
                proc.start()
            if proc.state == "starting" and proc.ready_key in self.alive and proc.pid:
                proc.state = "ready"
            elif proc.state == "starting" and now - proc.started_at > proc.spec.ready_timeout_s:
                awaiting = [s.name for s in self.waiting if proc.spec.name in s.after]
                log.error("%s did not become ready within %g s (no token %s)%s: stopped; its log: %s",
                          proc.spec.name, proc.spec.ready_timeout_s, proc.ready_key,
                          f"; {', '.join(awaiting)} wait for it" if awaiting else "", proc.log_path)
                proc.not_ready()

    def start_due(self) -> None:
        """Starts each waiting service once every service it comes after is ready; says once of each that
        cannot start because one of those failed for good."""
        for spec in list(self.waiting):
            states = {a: self.procs[a].state if a in self.procs else "waiting" for a in spec.after}
            if all(state == "ready" for state in states.values()):
                self.waiting.remove(spec)
                self.add(spec)
            elif "failed" in states.values() and spec.name not in self.blocked:
                self.blocked.add(spec.name)
                failed = [a for a, state in states.items() if state == "failed"]
                log.error("%s will not start: it comes after %s, which failed", spec.name, ", ".join(failed))
        if not self.announced and not self.waiting and self.all_ready():
            self.announced = True
            log.info("all %d services of %s are ready (%.1f s)", len(self.profile.services), self.profile.name,
                     time.monotonic() - self.up_since)

    def all_ready(self) -> bool:
        return all(p.state == "ready" for p in self.procs.values() if p.spec.box != "router")

    # --- a teacher's switch survives its restarts ------------------------------------------------
    def note_teaching(self, key: str, on: bool) -> None:
        """A teaching token comes and goes with the person's switch, and also when its teacher dies
        (its token may be gone a moment before the process is): a token gone just before its process
        died still counts as teaching (see restart_command)."""
        parts = key.split("/")
        if len(parts) == 5 and parts[2:4] == ["alive", "teaching"] and parts[4] in self.procs:
            self.teaching[parts[4]] = (on, time.monotonic())

    def restart_command(self, proc: ManagedProcess) -> list[str]:
        """A teacher comes back as the person left it: switched on if it was teaching when it died."""
        on, since = self.teaching.get(proc.spec.name, (proc.spec.options.on, 0.0))
        died_teaching = not on and proc.died_at - since < SWITCH_OFF_BEFORE_DEATH
        command = [arg for arg in proc.command if arg != "--on"]
        return command + ["--on"] if on or died_teaching else command

    # --- bus events -------------------------------------------------------------------------
    def on_event(self, item, session) -> None:
        tag, key, raw, kind = item
        if tag == "alive":
            (self.alive.add if kind == zenoh.SampleKind.PUT else self.alive.discard)(key)
            self.note_teaching(key, kind == zenoh.SampleKind.PUT)
        elif tag == "status":
            self.on_status(key, raw)
        else:
            self.on_control(key.rsplit("/", 1)[-1], raw, session)

    def on_status(self, key: str, raw: bytes) -> None:
        """A service's status, kept for `ps`: only one that says who it is where that service speaks."""
        try:
            msg = decode(Status, raw, key)
            check_name("status role", msg.role)
            check_name("status service", msg.name)
            if not key.endswith(f"/status/{msg.role}/{msg.name}"):
                raise ValueError(f"the status of {msg.role}/{msg.name} came on {key}")
        except ValueError as err:
            self.refused["status"] += 1
            if self.refused["status"] <= 10 or self.refused["status"] % 1000 == 0:
                log.warning("status refused (%d so far): %s", self.refused["status"], str(err)[:200])
            return
        member = f"{msg.role}/{msg.name}"
        self.status[member] = {"counters": msg.counters, "state": msg.state,
                               "rates": numeric_rates(msg.state.get("rates")), "pid": msg.pid,
                               "host": str(msg.state.get("host", "?"))[:64], "seen": time.monotonic(),
                               "instance": key.split("/")[1] if key.startswith("dl/") else ""}
        if member not in self.started and len(self.status) > len(self.started) + MAX_REMOTE:
            remote = sorted((k for k in self.status if k not in self.started), key=lambda k: self.status[k]["seen"])
            for forgotten in remote[:-MAX_REMOTE]:  # the stalest go first
                del self.status[forgotten]

    # --- what a swap asks of the supervisor ---------------------------------------------------
    def ready_learners(self) -> list[ManagedProcess]:
        return [p for p in self.procs.values() if p.spec.box == "learner" and p.state == "ready"]

    def retire(self, name: str) -> None:
        """Stops a service and forgets it (a learner swapped out, or its replacement that failed)."""
        self.procs.pop(name).stop()

    def reports(self, role: str, field: str, value) -> bool:
        """Whether a service of this role says in its status that `field` is `value`."""
        return any(s.get("state", {}).get(field) == value for m, s in self.status.items() if m.startswith(f"{role}/"))

    def status_of(self, spec: ServiceSpec) -> dict:
        return self.status.get(f"{spec.role}/{spec.name}", {})

    # --- the event loop ---------------------------------------------------------------------
    def pump(self, session, until=lambda: False, timeout: float = math.inf) -> bool:
        """The supervisor's one event loop (a swap waits in it too): starts what may start, handles bus
        events and verbs, watches processes. True once until() holds; False when the timeout passes or
        the profile is stopping (Ctrl-C, SIGTERM, `dogged down`)."""
        end = time.monotonic() + timeout
        while not (self.stopping or (self.stop_flag is not None and self.stop_flag)):
            self.start_due()
            self.handle_events(session)
            self.watch()
            if until():
                return True
            if time.monotonic() >= end:
                return False
        self.stopping = True
        return False

    # --- the run ----------------------------------------------------------------------------
    def router_problem(self) -> str:
        """"" once the profile's own router says it listens; else why it does not (its own words: a
        port another program or another profile's router holds, a mistyped endpoint)."""
        router = self.procs["router"]
        end = time.monotonic() + ROUTER_START_S
        while time.monotonic() < end:
            if any(ROUTING in line for line in list(router.tail)):
                return ""
            if router.proc.poll() is not None:
                time.sleep(0.3)  # its last lines, still on their way through the pipe
                said = [line[line.index(CANNOT_LISTEN):] for line in list(router.tail) if CANNOT_LISTEN in line]
                return (said[-1] if said else
                        f"the router exited with {router.proc.returncode} (see {router.log_path})")
            time.sleep(0.05)
        return f"the router did not say it listens on {self.profile.router} within {ROUTER_START_S:g} s " \
               f"(see {router.log_path})"

    def run(self) -> int:
        self.stop_flag = StopFlag()
        prof = self.profile
        if prof.low_latency and hold_low_latency(log):
            log.info("low latency: CPUs kept out of deep idle while %s runs", prof.name)
        if prof.placement is not None:  # this process watches and restarts: the tick path's CPUs are not its
            move_process(prof.placement.rest)
            log.info("%s", prof.placement.describe())
        for spec in prof.services:  # before any starts: a learner swapped in last run left the newest pairs
            if spec.box == "learner":
                adopt_successor_log(prof.state_dir_of(spec), spec.name)
        router_spec = self.secured(ServiceSpec("router", "router", "", restart="on-failure"), "router.router")
        if prof.security is not None:  # this process's own session, before it opens
            me = f"supervisor.{prof.name}"
            os.environ.update(DOGGED_SECURITY=str(prof.security / me), DOGGED_IDENTITY=me)
            log.info("roster of %d identities read now: %s (a certificate made later gets nothing until the "
                     "profile restarts)", len(self.roster), ", ".join(self.roster))
        listen = sum((["--listen", e] for e in (prof.router, *prof.also_listen)), ["--token", router_token(prof.name)])
        if prof.upstream:
            listen += ["--connect", prof.upstream]
            log.info("linking to the router at %s (another machine runs it)", prof.upstream)
        router = self.procs["router"] = self.process(router_spec, box_command("router", *listen))
        router.start()
        problem = self.router_problem()
        if problem:  # its session would wait for ever, or join whichever router holds the port
            log.error("%s: nothing started", problem)
            router.stop()
            return 1
        announced = self.announce()
        try:
            return self.supervise(router)
        finally:
            if announced:
                withdraw(prof.router)

    def announce(self) -> bool:
        """Tell this user's verbs where the router runs and as whom to speak to it (services/own_identities.py);
        False when the per-user folder is not this user's alone (then the verbs need their flags)."""
        try:
            announce(self.profile.router, self.profile.security, self.roster, self.profile.name)
            return True
        except (NotPrivate, OSError) as err:
            log.warning("this user's verbs will not find %s without --connect and --security: %s", self.profile.name,
                        err)
            return False

    def supervise(self, router: ManagedProcess) -> int:
        """Run the profile on the router started, until it is stopped; then stop every process."""
        prof = self.profile
        conf = zenoh_config(connect=[prof.router], mode="client")
        with zenoh.open(conf) as session:
            held = []  # declarations live as long as these references (a dropped token is undeclared)
            held.append(session.liveliness().declare_subscriber(EVERY_ALIVE, self.inbox.callback("alive"),
                                                                history=True))
            # the router's own token: a restarted router is ready again once it is back
            router.state = "ready"
            router.ready_key = router_token(prof.name)
            held.append(session.liveliness().declare_subscriber(router_token(prof.name), self.inbox.callback("alive"),
                                                                history=True))
            held.append(session.declare_subscriber(EVERY_STATUS, self.inbox.callback("status")))
            held.append(session.declare_queryable(supervisor_key(prof.name, "*"),
                                                  self.inbox.query_callback("control")))
            held.append(session.liveliness().declare_token(supervisor_token(prof.name)))
            self.waiting, self.up_since = list(prof.services), time.monotonic()
            self.pump(session)  # until the profile is stopping
            log.info("stopping %s", prof.name)
            self.answer_deferred()
            for proc in reversed([p for p in self.procs.values() if p.spec.box != "router"]):
                proc.stop()
        router.stop()
        killed = [proc for proc in self.procs.values() if proc.killed]
        if killed:  # what they had not written (a recording's index, a summary) may be missing: say so
            log.warning("stopped; no process left, but %s did not stop on SIGTERM and %s killed: see %s",
                        ", ".join(p.spec.name for p in killed), "was" if len(killed) == 1 else "were",
                        ", ".join(str(p.log_path) for p in killed))
        else:
            log.info("stopped; no process left")
        return 0


def numeric_rates(rates) -> dict:
    """A status's nonzero rates, from the bus: a forged or malformed entry is left out."""
    if not isinstance(rates, dict):
        return {}
    return {k: v for k, v in rates.items() if isinstance(k, str) and type(v) in (int, float) and math.isfinite(v)
            and v}
