"""Deploy profiles: declarative data (TOML), validated at start with errors that name the field."""
from __future__ import annotations

import argparse
import time
import tomllib
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

from bus_schema import check_name
from services.boxes import BOX_ROLES, parse_box_args
from services.own_identities import identities_dir, secured_endpoint
from services.placement import Placement, PlacementError, plan

BOXES = tuple(box for box in BOX_ROLES if box != "router")  # the supervisor starts the profile's router itself
RESTART = ("never", "on-failure", "always")
OWN = "own"  # zenoh.security's default: this user's own identities (services/own_identities.py)
SECURE_SCHEMES = ("tls", "quic")  # Zenoh links with mutual TLS: over TCP, and over UDP


class ProfileError(ValueError):
    pass


@dataclass(frozen=True)
class ServiceSpec:
    name: str
    box: str
    instance: str
    args: tuple[str, ...] = ()
    restart: str = "on-failure"
    max_restarts: int = 5
    backoff_s: float = 0.5
    ready_timeout_s: float = 60.0
    env: dict = field(default_factory=dict)
    after: tuple[str, ...] = ()   # start once these services are ready
    stands_for: str = ""          # a hot-swapped learner: the profile's learner service it replaces

    @cached_property
    def options(self) -> argparse.Namespace:
        """Its arguments as its box reads them (services.boxes.parse_box_args): the one reading of them."""
        return parse_box_args(self.box, self.args)

    @property
    def role(self) -> str:
        """The role in the service's liveliness token dl/<instance>/alive/<role>/<name>."""
        return self.options.role if self.box == "demonstrator" else self.box


@dataclass(frozen=True)
class Profile:
    name: str
    path: Path
    router: str
    log_dir: Path
    services: tuple[ServiceSpec, ...]
    low_latency: bool = False  # hold a PM QoS request so CPUs stay out of deep idle (services.realtime)
    # the tick path on CPUs of its own (services.placement): "auto", "off" or a list of CPU numbers
    tick_cpus: str | list = "auto"
    # a `dogged certs` directory (a folder per identity): mutual TLS and access control; None: "off"
    security: Path | None = None
    # where learners keep every pair they learned (their --state-dir unless they name one), so a restarted
    # learner comes back knowing what it was taught; None: learners without a --state-dir forget
    state_dir: Path | None = None
    # another machine's router (`dogged up --join ENDPOINT`): this profile's router links to it, so the
    # services here talk among themselves on this machine and only what the other side needs crosses
    upstream: str | None = None
    also_listen: tuple[str, ...] = ()  # more endpoints the router listens on (a quic/ one for a radio link)
    own_security: bool = False  # `security` is this user's own identities (the default), made at `up`

    @cached_property
    def placement(self) -> Placement | None:
        """Where its processes run (services.placement; None: anywhere), among the CPUs this process may use."""
        return plan(self.tick_cpus)

    def service_args(self, spec: ServiceSpec) -> tuple[str, ...]:
        """The service's arguments, with the profile's state directory for a learner that names none."""
        if spec.box == "learner" and self.state_dir is not None and spec.options.state_dir is None:
            return (*spec.args, "--state-dir", str(self.state_dir))
        return spec.args

    def where_things_go(self) -> str:
        """Where this profile keeps its learners' state, its logs and its recordings, for a person to read."""
        recorder = [s for s in self.services if s.box == "recorder"]
        recordings = (recorder[0].options.out or "(the recorder's own default)") if recorder else "not recorded"
        state = self.state_dir or "not kept (state_dir = \"\")"
        security = ("off: anyone on this machine may drive the robot" if self.security is None else
                    f"this user's own identities in {self.security} (the router at {self.router})"
                    if self.own_security else f"{self.security} (the router at {self.router})")
        return f"state: {state}\nlogs: {self.log_dir}\nrecordings: {recordings}\nsecurity: {security}"

    def state_dir_of(self, spec: ServiceSpec) -> Path | None:
        """Where a learner keeps its pairs: its own --state-dir, else the profile's (None: nowhere)."""
        return Path(spec.options.state_dir) if spec.options.state_dir is not None else self.state_dir

    def identity(self, spec: ServiceSpec) -> str:
        """The certificate a service of this profile shows: <role>.<service name>."""
        return f"{BOX_ROLES[spec.box]}.{spec.stands_for or spec.name}"

    def identities(self) -> list[str]:
        """Every certificate the profile needs: the router's, the supervisor's, each service's."""
        return ["router.router", f"supervisor.{self.name}"] + [self.identity(s) for s in self.services]


def _get(table: dict, key: str, kind, where: str, default=None, choices=None):
    value = table.get(key, default)
    if value is None:
        raise ProfileError(f"{where}.{key}: required")
    ok = isinstance(value, kind) and not (kind in (int, float, (int, float)) and isinstance(value, bool))
    if not ok:
        kind_name = getattr(kind, "__name__", "number")
        raise ProfileError(f"{where}.{key}: expected {kind_name}, got {value!r}")
    if choices and value not in choices:
        raise ProfileError(f"{where}.{key}: expected one of {', '.join(choices)}, got {value!r}")
    return value


def _service(name: str, table: dict, instance: str, where: str) -> ServiceSpec:
    known = {"box", "args", "instance", "restart", "max_restarts", "backoff_s", "ready_timeout_s", "env", "after"}
    for key in table:
        if key not in known:
            raise ProfileError(f"{where}.{key}: unknown field; known: {', '.join(sorted(known))}")
    try:
        check_name("service", name)
    except ValueError as err:
        raise ProfileError(f"{where}: {err}") from None
    args = _get(table, "args", list, where, [])
    if not all(isinstance(a, str) for a in args):
        raise ProfileError(f"{where}.args: expected a list of strings")
    after = _get(table, "after", list, where, [])
    if not all(isinstance(a, str) for a in after):
        raise ProfileError(f"{where}.after: expected a list of service names")
    spec = ServiceSpec(
        name=name, box=_get(table, "box", str, where, choices=BOXES),
        instance=_get(table, "instance", str, where, instance), args=tuple(args),
        restart=_get(table, "restart", str, where, "on-failure", RESTART),
        max_restarts=_get(table, "max_restarts", int, where, 5),
        backoff_s=float(_get(table, "backoff_s", (int, float), where, 0.5)),
        ready_timeout_s=float(_get(table, "ready_timeout_s", (int, float), where, 60.0)),
        env={str(k): str(v) for k, v in _get(table, "env", dict, where, {}).items()}, after=tuple(after))
    if spec.max_restarts < 0 or spec.backoff_s < 0 or spec.ready_timeout_s <= 0:
        raise ProfileError(f"{where}: max_restarts and backoff_s must be >= 0, ready_timeout_s > 0")
    try:
        spec.options  # noqa: B018 - read once here: a mistyped argument stops `up` before anything starts
    except ValueError as err:
        raise ProfileError(f"{where}.args: {spec.box} refuses them: {err}") from None
    return spec


def load_profile(path: str | Path, router: str | None = None, check_security: bool = True,
                 join: str | None = None) -> Profile:
    """A profile from TOML; `join`: the endpoint of a router another machine runs, which this profile's
    router links to."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise ProfileError(f"{path}: no such profile") from None
    except tomllib.TOMLDecodeError as err:
        raise ProfileError(f"{path}: not valid TOML: {err}") from None
    for key in data:
        if key not in ("profile", "zenoh", "services"):
            raise ProfileError(f"{path}: {key}: unknown table; known: profile, zenoh, services")
    head = data.get("profile", {})
    for key in head:
        if key not in HEAD_FIELDS:
            raise ProfileError(f"profile.{key}: unknown field; known: {', '.join(HEAD_FIELDS)}")
    name = _get(head, "name", str, "profile", path.stem.replace(".", "-"))
    instance = _get(head, "instance", str, "profile", "main")
    try:
        check_name("profile", name), check_name("instance", instance)
    except ValueError as err:
        raise ProfileError(f"profile: {err}") from None
    base = path.resolve().parent  # relative paths in a profile are the profile file's, wherever `up` is run
    log_dir = base / _get(head, "log_dir", str, "profile", f"runs/{name}/logs")
    state_dir = _get(head, "state_dir", str, "profile", str(log_dir.parent / "state"))  # "": no state kept
    low_latency = _get(head, "low_latency", bool, "profile", False)
    tick_cpus = head.get("tick_cpus", "auto")  # its kind and CPUs checked below, by placement
    router = router or _get(data.get("zenoh", {}), "router", str, "zenoh", "tcp/127.0.0.1:7447")
    services = data.get("services")
    if not isinstance(services, dict) or not services:
        raise ProfileError("services: at least one [services.<name>] table is required")
    specs = tuple(_with_state_dir_under(_service(n, t if isinstance(t, dict) else {}, instance, f"services.{n}"), base)
                  for n, t in services.items())
    specs = _with_recorder(specs, head, instance, log_dir, base)
    names = {s.name for s in specs}
    for spec in specs:
        for other in spec.after:
            if other not in names or other == spec.name:
                raise ProfileError(f"services.{spec.name}.after: {other!r} is not another service of this profile")
    _check_no_cycle(specs)
    zenoh_table = data.get("zenoh", {})
    for key in zenoh_table:
        if key not in ("router", "security", "also_listen"):
            raise ProfileError(f"zenoh.{key}: unknown field; known: router, security, also_listen")
    security = _get(zenoh_table, "security", str, "zenoh", OWN)
    if not security:
        raise ProfileError(f'zenoh.security: expected "{OWN}" (the default), "off" or a `dogged certs` directory, '
                           'got ""')
    also_listen = _get(zenoh_table, "also_listen", list, "zenoh", [])
    if not all(isinstance(e, str) and "/" in e for e in also_listen):
        raise ProfileError("zenoh.also_listen: expected a list of endpoints like quic/10.0.0.1:7447, "
                           f"got {also_listen!r}")
    own = security == OWN
    if own:  # this user's identities (services/own_identities.py): the same ports, over TLS
        if join:
            raise ProfileError("--join: another machine's router shares no CA with this user's own identities: set "
                               "zenoh.security to a `dogged certs` directory both machines use")
        router, also_listen = secured_endpoint(router), [secured_endpoint(e) for e in also_listen]
    directory = identities_dir() if own else None if security == "off" else base / security
    profile = Profile(name, path, router, log_dir, specs, low_latency, tick_cpus, directory,
                      base / state_dir if state_dir else None, upstream=join, also_listen=tuple(also_listen),
                      own_security=own)
    try:  # worked out once, here (cached): a tick_cpus that cannot be had stops the profile at load
        _ = profile.placement
    except PlacementError as err:
        raise ProfileError(f"profile.tick_cpus: {err}") from None
    if check_security and not own:  # this user's own are made at `up` (ensure_security)
        check_security_files(profile)
    return profile


def ensure_security(profile: Profile) -> None:
    """At `dogged up`: a profile secured by this user's own identities gets those it lacks; then every
    secured profile is checked (ProfileError saying what is missing or wrong)."""
    if profile.own_security:
        from services.own_identities import NotPrivate, ensure_identities
        try:
            ensure_identities(profile.identities())
        except (NotPrivate, ValueError, OSError) as err:
            raise ProfileError(f"zenoh.security: this user's own identities: {err}") from None
    check_security_files(profile)


def check_security_files(profile: Profile) -> None:
    """A secured profile routes over tls/ and has every certificate it needs; tls/ needs security."""
    scheme = profile.router.split("/", 1)[0]
    if profile.security is None:
        if scheme in SECURE_SCHEMES:
            raise ProfileError(f"zenoh.router: a {scheme}/ endpoint needs zenoh.security (a `dogged certs` directory)")
        return
    endpoints = [("zenoh.router", "the router listens on", profile.router),
                 ("--join", "the other machine's router is reached on", profile.upstream),
                 *(("zenoh.also_listen", "every endpoint is", e) for e in profile.also_listen)]
    for where, must, endpoint in endpoints:
        if endpoint is not None and endpoint.split("/", 1)[0] not in SECURE_SCHEMES:
            raise ProfileError(f"{where}: with zenoh.security {must} tls/... (or quic/...), got {endpoint!r}")
    keys_on_top = sorted(p.name for p in profile.security.glob("*.key"))
    if keys_on_top:  # the CA's, or every identity's side by side (before issue 30): any service could read them
        raise ProfileError(f"zenoh.security: {profile.security} holds {', '.join(keys_on_top)} at its top: the CA's "
                           "key belongs outside it and each identity's in its own folder; move ca.key and ca.pem "
                           f"to {profile.security}-ca, remove the rest and run `dogged certs {profile.security} "
                           f"--profile {profile.path}`")
    missing = [cn for cn in profile.identities()
               if not all((profile.security / cn / name).is_file() for name in (f"{cn}.pem", f"{cn}.key", "ca.pem"))]
    if not (profile.security / "ca.pem").is_file() or missing:
        raise ProfileError(f"zenoh.security: {profile.security} lacks {', '.join(missing) or 'ca.pem'}; make them "
                           f"with `dogged certs {profile.security} --profile {profile.path}`")


HEAD_FIELDS = ("name", "instance", "log_dir", "state_dir", "low_latency", "tick_cpus", "record", "record_dir",
               "record_rotate_mb", "record_rotate_min")


def _with_state_dir_under(spec: ServiceSpec, base: Path) -> ServiceSpec:
    """The service with a relative `--state-dir DIR` (or `--state-dir=DIR`) in its args made `base`/DIR."""
    args = list(spec.args)
    for i, arg in enumerate(args):
        if arg == "--state-dir" and i + 1 < len(args):
            args[i + 1] = str(base / args[i + 1])
        elif arg.startswith("--state-dir="):
            args[i] = "--state-dir=" + str(base / arg.split("=", 1)[1])
    return replace(spec, args=tuple(args))


def _with_recorder(specs: tuple[ServiceSpec, ...], head: dict, instance: str, log_dir: Path, base: Path) -> tuple:
    """The profile's services and, unless `record = false` or the profile runs a recorder of its own, a
    recorder of every instance and robot they use, into <record_dir>/<the time of `up`>/ (first, so the
    run is recorded from its start)."""
    record = _get(head, "record", bool, "profile", True)
    folder = base / _get(head, "record_dir", str, "profile", str(log_dir.parent / "recordings"))
    rotate_mb = _get(head, "record_rotate_mb", (int, float), "profile", 512)
    rotate_min = _get(head, "record_rotate_min", (int, float), "profile", 30)
    if rotate_mb <= 0 or rotate_min <= 0:
        raise ProfileError("profile: record_rotate_mb and record_rotate_min must be > 0")
    if not record or any(s.box == "recorder" for s in specs):
        return specs
    if any(s.name == "recorder" for s in specs):
        raise ProfileError("services.recorder: the name of the profile's recorder; name this service otherwise "
                           "or set profile.record = false")
    instances = list(dict.fromkeys([instance] + [s.instance for s in specs]))
    robots = list(dict.fromkeys(s.options.robot for s in specs if s.box in ("aibo", "perception")))
    args = [arg for i in instances[1:] for arg in ("--instance", i)] + [a for r in robots for a in ("--robot", r)]
    run = folder / time.strftime("%Y-%m-%dT%H-%M-%S", time.localtime())
    args += ["--out", str(run), "--rotate-mb", str(rotate_mb), "--rotate-min", str(rotate_min)]
    return (ServiceSpec("recorder", "recorder", instance, tuple(args), restart="always", max_restarts=100), *specs)


def _check_no_cycle(specs) -> None:
    after = {s.name: set(s.after) for s in specs}
    done: set[str] = set()
    while after:
        free = [n for n, deps in after.items() if deps <= done]
        if not free:
            raise ProfileError(f"services: 'after' makes a cycle among {', '.join(sorted(after))}")
        for n in free:
            done.add(n)
            del after[n]
