"""Platforms by name. Entries are import paths so that `import pybullet` happens only when asked."""
from __future__ import annotations

import importlib

PLATFORMS: dict[str, str] = {
    "point": "services.platforms.point:PointPlatform",
    "aibo": "services.platforms.aibo.platform:AiboPlatform",
    "recorded": "services.recording.platform:RecordedPlatform",  # a recorded run played back (`dogged play`)
    "gym": "services.platforms.gym:GymPlatform",  # any Gymnasium environment with a Box observation (env=...)
}


def platform_class(name: str) -> type:
    if name not in PLATFORMS:
        raise KeyError(f"unknown platform {name!r}; known: {', '.join(sorted(PLATFORMS))}")
    module, cls = PLATFORMS[name].split(":")
    return getattr(importlib.import_module(module), cls)


def make_platform(name: str, **params):
    return platform_class(name)(**params)
