"""The learner registry: each learner module registers its class by name; make_learner builds one.

It imports no learner, so a learner that builds others by name (per-output) can use it.
"""
from __future__ import annotations

import numpy as np

from . import snapshot_codec
from .base import TaughtRange
from .errors import UnknownLearnerError
from .gp_evidence import Hyper
from .gp_fitting import stop_fitting
from .novelty import InputEnvelope

LEARNERS: dict[str, type] = {}
snapshot_codec.allow(TaughtRange, Hyper, InputEnvelope)  # the state classes learners share


def register(name: str, cls: type) -> type:
    """Registers a learner class under `name`; snapshots may name it and the state classes it declares."""
    LEARNERS[name] = cls
    snapshot_codec.allow(cls, *cls.state_classes)
    return cls


def make_learner(name: str, n_in: int, n_out: int, seed: int = 0, **hyper_parameters):
    """Build a registered learner; unknown names raise UnknownLearnerError (a KeyError),
    unknown or invalid hyper-parameters a ValueError naming the parameter."""
    try:
        cls = LEARNERS[name]
    except KeyError:
        known = ", ".join(sorted(LEARNERS))
        raise UnknownLearnerError(f"unknown learner {name!r}; known learners: {known}") from None
    accepted = cls.param_names()
    for key in hyper_parameters:
        if key not in accepted:
            raise ValueError(f"unknown hyper-parameter {key!r} for {name}; accepted: {', '.join(accepted)}")
    return cls(n_in, n_out, seed=seed, **hyper_parameters)


def parse_learner_spec(text: str) -> tuple[str, list[str]]:
    """A learner spec as `dogged swap`, `dogged replay` and `dogged export` take it: 'sogp' or
    'sogp:capacity=200,noise=0.01' -> ('sogp', ['--param', 'capacity=200', ...]), the learner box's flags;
    a ValueError for a malformed spec or a learner not registered."""
    name, _, rest = text.partition(":")
    params = []
    for item in filter(None, rest.split(",")):
        if "=" not in item:
            raise ValueError(f"learner spec {text!r}: {item!r} is not name=value")
        params += ["--param", item]
    if not name:
        raise ValueError("learner spec is empty; expected e.g. 'sogp' or 'lwpr:init_d=25'")
    if name not in LEARNERS:  # refused at once, not after a learner that cannot start has timed out
        raise ValueError(f"no learner {name!r}; learners: {', '.join(sorted(LEARNERS))}")
    return name, params


def start_upkeep(model) -> None:
    """Start what serving live will need (the GP's fitting processes) with the service, by a throw-away copy that
    serves live; the model itself learns as offline until it is told to serve live. Started at the model's
    serve_live, after a catch-up, the fitting processes (~400 MB) came as growth of a service running for minutes."""
    model.clone().serve_live()


def stop_upkeep() -> None:
    """The service is ending: upkeep still queued or under way (the GP's fits) is dropped and its processes end."""
    stop_fitting()


def compile_kernels(model) -> None:
    """Run a throw-away copy once, so compiled kernels are built before this learner says it is ready: it learns,
    answers, and is snapshot and restored (which answers a batch), as a swap asks of a learner while it serves.
    Left to the first swap, an LWPR learner compiled its snapshot's kernels on the answer path: 2.4 s there, and
    0.8 s to restore, with numba's cache empty (a new install)."""
    scratch = model.clone()
    rng = np.random.default_rng(0)
    for _ in range(3):  # varied samples: some learners (GP) build their model only once targets vary
        scratch.learn_one(rng.uniform(-1.0, 1.0, model.n_in), rng.uniform(-1.0, 1.0, model.n_out))
    scratch.predict_one(np.zeros(model.n_in))
    scratch.warm_served()  # the answer served live takes kernels of its own (the GP's)
    type(scratch).restore(scratch.snapshot())
