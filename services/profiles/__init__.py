"""The deploy profiles as package data: each deploy/<name>.toml of the repository (what `dogged up
deploy/<name>.toml` runs, and where its runs go) is linked here, and the wheel carries its text, so an
installed dogged finds a profile by name (the experiments read the learner one wires).

A new profile in deploy/ is linked here too: `ln -s ../../deploy/NAME.toml services/profiles/`
(tests/test_wheel.py fails on a profile of deploy/ the wheel does not carry).
"""
from __future__ import annotations

from importlib.resources import files
from pathlib import Path


def profile_names() -> list[str]:
    return sorted(entry.name.removesuffix(".toml") for entry in files(__name__).iterdir()
                  if entry.name.endswith(".toml"))


def profile_path(name: str) -> Path:
    """The file of the profile `name` (ballseek, mirroring, ...); a ValueError naming those there are."""
    if name not in profile_names():
        raise ValueError(f"no profile {name!r}; profiles: {', '.join(profile_names())}")
    return Path(str(files(__name__).joinpath(f"{name}.toml")))
