"""Platform conformance checks (river's `checks`, Gymnasium's env checker): run on every platform.

Each `check_*` takes a `platform_factory(seed=...)` returning a fresh platform, and raises
AssertionError saying what is wrong and what to fix. `ALL_CHECKS` lists them in order;
tests/test_platform_conformance.py runs each over every registered platform.
"""
from __future__ import annotations

from collections.abc import Callable
from contextlib import closing

import numpy as np

from bus_schema.spaces import Box, Spaces
from services.platforms.base import Platform

DT = 0.05  # seconds per step: a 20 Hz control loop is slow enough for any platform to respond
STEPS = 20
HOLD_TOLERANCE = 0.02  # of each input's range: how far a held input may wander
MAX_HOLD_SETTLE_SECONDS = 0.5  # the longest a platform may declare for hold() to bring it to rest
# what a platform must have: the Platform protocol's attributes and methods
CONTRACT = (*Platform.__annotations__, *(n for n, v in vars(Platform).items() if callable(v) and not n.startswith("_")))


def _random_commands(box: Box, count: int, rng: np.random.Generator, spread: float) -> np.ndarray:
    """Commands around the box's centre; spread 1 stays inside the box, 3 goes far outside."""
    centre = (np.asarray(box.low) + np.asarray(box.high)) / 2
    half = (np.asarray(box.high) - np.asarray(box.low)) / 2
    return centre + spread * half * rng.uniform(-1.0, 1.0, size=(count, box.dims))


def _as_applied(spaces: Spaces, clipped: np.ndarray) -> np.ndarray:
    """What a platform applies of a clipped command: itself, or where the outputs are a choice
    (spaces.extra["choice"] == "largest": one output per action) the one-hot of the largest."""
    if spaces.extra.get("choice") != "largest":
        return clipped
    chosen = np.zeros_like(clipped)
    chosen[int(np.argmax(clipped))] = 1.0
    return chosen


def _assert_input(platform, x, what: str) -> None:
    box = platform.spaces.input
    assert isinstance(x, np.ndarray), f"{what} returned {type(x).__name__}; return a numpy array"
    assert x.dtype == np.float64, f"{what} returned dtype {x.dtype}; return float64"
    assert x.shape == (box.dims,), f"{what} returned shape {x.shape}; spaces.input declares {box.dims} inputs"
    outside = [n for n, v, lo, hi in zip(box.names or range(box.dims), x, box.low,
                                         box.high) if not lo - 1e-9 <= v <= hi + 1e-9]
    assert not outside, f"{what} returned inputs outside spaces.input: {outside}; clip them or widen the bounds"


def check_spaces_declared_as_data(platform_factory: Callable) -> None:
    with closing(platform_factory(seed=0)) as platform:
        missing = [m for m in CONTRACT if not hasattr(platform, m)]
        assert not missing, f"{type(platform).__name__} lacks {', '.join(missing)} of the Platform contract " \
                            "(services/platforms/base.py)"
        spaces = platform.spaces
        assert isinstance(spaces,
                          Spaces), f"platform.spaces is {type(spaces).__name__}; declare a bus_schema.spaces.Spaces"
        for side in ("input", "output"):
            box = getattr(spaces, side)
            assert isinstance(box, Box), f"spaces.{side} is {type(box).__name__}; declare a Box"
            assert np.all(np.isfinite(box.low)) and np.all(np.isfinite(box.high)), \
                f"spaces.{side} has infinite bounds; give finite ones"
            assert len(box.names) == box.dims, \
                f"spaces.{side} names {len(box.names)} of {box.dims} dimensions; name every one"
            assert len(set(box.names)) == box.dims, f"spaces.{side} has repeated names; make them unique"
        assert Spaces.from_dict(spaces.to_dict()) == spaces, \
            "spaces do not survive to_dict/from_dict; keep extra JSON-like"


def check_reset_returns_input(platform_factory: Callable) -> None:
    with closing(platform_factory(seed=0)) as platform:
        x = platform.reset(seed=0)
        _assert_input(platform, x, "reset()")
        _assert_input(platform, platform.observe(), "observe()")
        assert np.array_equal(x, platform.observe()), "observe() right after reset() differs from what reset() returned"


def check_step_clips_command(platform_factory: Callable) -> None:
    with closing(platform_factory(seed=0)) as platform:
        platform.reset(seed=0)
        box, rng = platform.spaces.output, np.random.default_rng(0)
        for spread in (0.9, 3.0):
            for command in _random_commands(box, 3, rng, spread):
                applied = platform.step(command.copy(), DT)
                assert isinstance(applied, np.ndarray) and applied.shape == (box.dims,), (
                    f"step() returned {type(applied).__name__} {getattr(applied, 'shape', '')}; "
                    f"return the applied command, shape ({box.dims},)")
                assert np.allclose(applied, _as_applied(platform.spaces, box.clip(command))), (
                    f"step() reported {np.round(applied, 4).tolist()} for command {np.round(command, 4).tolist()}; "
                    "report the command clipped to spaces.output, as applied")


def check_limits_respected(platform_factory: Callable) -> None:
    """Commands far outside the output space must not drive the inputs outside theirs."""
    with closing(platform_factory(seed=0)) as platform:
        platform.reset(seed=0)
        for i, command in enumerate(_random_commands(platform.spaces.output, STEPS, np.random.default_rng(1), 3.0)):
            platform.step(command, DT)
            _assert_input(platform, platform.observe(), f"observe() after {i + 1} out-of-range commands")


def check_watchdog_holds_still(platform_factory: Callable) -> None:
    """hold() keeps still what the commands move, once its declared `hold_settle_seconds` (0 if
    absent, at most MAX_HOLD_SETTLE_SECONDS) have passed. Two twins get the same commands; then one
    holds while the other is sent the mirror image of the last command. After the settle, an input
    may change only as it also changes in the twin (the world going on, not the robot moving)."""
    with closing(platform_factory(seed=0)) as held, closing(platform_factory(seed=0)) as twin:
        settle = getattr(held, "hold_settle_seconds", 0.0)
        assert isinstance(settle, (int, float)) and 0.0 <= settle <= MAX_HOLD_SETTLE_SECONDS, (
            f"hold_settle_seconds is {settle!r}; declare a number of seconds from 0 to {MAX_HOLD_SETTLE_SECONDS}: "
            "a watchdog that takes longer to stop the robot is no watchdog")
        held.reset(seed=0)
        twin.reset(seed=0)
        box = held.spaces.output
        commands = _random_commands(box, 6, np.random.default_rng(2), 1.0)
        for command in commands:
            held.step(command, DT)
            twin.step(command, DT)
        mirrored = np.asarray(box.low) + np.asarray(box.high) - commands[-1]
        for _ in range(int(np.ceil(settle / DT - 1e-9))):
            held.hold(DT)
            twin.step(mirrored, DT)
        before = held.observe()
        for _ in range(STEPS):
            held.hold(DT)
            twin.step(mirrored, DT)
        after, elsewhere = held.observe(), twin.observe()
        inputs = held.spaces.input
        tolerance = HOLD_TOLERANCE * (np.asarray(inputs.high) - np.asarray(inputs.low))
        moved = (np.abs(after - before) > tolerance) & (np.abs(after - elsewhere) > tolerance)
        names = [inputs.names[i] for i in np.flatnonzero(moved)]
        assert not names, (f"hold() let {names} move by {np.round(np.abs(after - before)[moved], 4).tolist()}; "
                           "the watchdog must keep the robot still when commands stop")


def check_close_idempotent(platform_factory: Callable) -> None:
    platform = platform_factory(seed=0)
    platform.reset(seed=0)
    platform.close()
    platform.close()  # a second close must be harmless: services close on every exit path


def check_seeded_determinism(platform_factory: Callable) -> None:
    """Same seed and same commands give the same inputs, in a new platform and after reset()."""
    runs = []
    with closing(platform_factory(seed=7)) as first, closing(platform_factory(seed=7)) as second:
        box = first.spaces.output
        commands = _random_commands(box, 8, np.random.default_rng(3), 1.5)
        for platform in (first, second, first):
            trace = [platform.reset(seed=7)]
            for command in commands:
                platform.step(command, DT)
                trace.append(platform.observe())
            runs.append(np.array(trace))
    for label, run in (("a second platform", runs[1]), ("reset() of the first", runs[2])):
        assert np.array_equal(runs[0], run), (
            f"seed 7 gave different inputs in {label} (max difference {np.abs(runs[0] - run).max():.3g}); "
            "draw all randomness from the seed and rebuild the world on reset")


ALL_CHECKS = (
    check_spaces_declared_as_data,
    check_reset_returns_input,
    check_step_clips_command,
    check_limits_respected,
    check_watchdog_holds_still,
    check_close_idempotent,
    check_seeded_determinism,
)

