"""The learner a deploy profile wires, read from the profile itself: the experiments measure the
system as a user starts it, and one place says which learner and which settings."""
from __future__ import annotations

from services.params import parse_params
from services.profiles import profile_path
from services.supervisor.profile import load_profile


def wired_learner(profile: str, instance: str | None = None) -> tuple[str, dict]:
    """(learner name, hyper-parameters) of the learner service in deploy/<profile>.toml (of `instance`,
    where the profile runs several), as the package carries it (services.profiles)."""
    services = load_profile(profile_path(profile)).services
    spec = next((s for s in services if s.box == "learner" and instance in (None, s.instance)), None)
    if spec is None:
        raise ValueError(f"deploy/{profile}.toml starts no learner" + (f" for instance {instance}" if instance else ""))
    return spec.options.learner, parse_params(spec.options.param)


def wired_spec(profile: str) -> str:
    """The learner deploy/<profile>.toml wires, as a `dogged swap` or replay spec ('per-output:base=gp')."""
    learner, params = wired_learner(profile)
    return learner + (":" + ",".join(f"{k}={v}" for k, v in params.items()) if params else "")
