"""deploy/ballseek.toml with its page (`dogged ui`), brought up for the page's tests and benchmark: the
profile file itself, its page on a given port, its learner's state and the logs in the run's folder;
and a scripted person who teaches ball seeking through the page's arrow keys."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from bus_schema import Command, Input
from rigs.harness import REPO
from services.demo.ballseek import LiveStage
from services.demo.live import LiveRun, decoded, when_ready
from services.teachers import make_teacher
from services.waiting import poll

PROFILE = REPO / "deploy" / "ballseek.toml"
PAGE_ADDRESS = '"127.0.0.1:8080"'
STATE_DIR = '"runs/ballseek/state"'


def start_ballseek_with_page(run_dir: Path, endpoint: str, port: int) -> LiveRun:
    text = PROFILE.read_text()
    for part in (PAGE_ADDRESS, STATE_DIR, "[profile]\n"):
        if part not in text:
            raise ValueError(f"{PROFILE} no longer holds {part.strip()}: update rigs/live/page.py")
    text = (text.replace(PAGE_ADDRESS, f'"127.0.0.1:{port}"').replace(STATE_DIR, f'"{run_dir / "state"}"')
            .replace("[profile]\n", f'[profile]\nlog_dir = "{run_dir / "logs"}"\n', 1))
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "ballseek.toml").write_text(text)
    return when_ready(LiveRun(run_dir / "ballseek.toml", run_dir, endpoint))


class KeyboardPerson:
    """A scripted person at the page who knows ball seeking: each tick it looks at what the robot sees
    (the instance's newest input) and holds the arrow keys the ball-seeking teacher's answer asks for:
    up for forward, left or right for a turn (bang-bang, as keys are), nothing otherwise."""

    FORWARD_AT, TURN_AT = 0.4, 0.25  # fractions of the output's range that make the person press

    def __init__(self, page, spaces):
        self.page, self.held = page, set()
        self.policy = make_teacher("ballseek", spaces)
        self.high = np.asarray(spaces.output.high, dtype=np.float64)

    def keys_for(self, x: np.ndarray) -> set[str]:
        y, _ = self.policy(x)
        if y is None:
            return set()
        f, t = np.asarray(y) / self.high
        return ({"ArrowUp"} if f > self.FORWARD_AT else set()) | (
            {"ArrowLeft"} if t > self.TURN_AT else {"ArrowRight"} if t < -self.TURN_AT else set())

    def press(self, keys: set[str]) -> None:
        for key in sorted(self.held - keys):
            self.page.keyboard.up(key)
        for key in sorted(keys - self.held):
            self.page.keyboard.down(key)
        self.held = set(keys)


# the Gamepad API as a pad plugged in shows it, for a page in headless chromium (which has no pads): one pad
# whose axes the person sets (axis 0: stick right positive; axis 1: stick down positive)
PAD_PLUGGED = """() => { window.doggedPad = {id: 'scripted stick', axes: [0.0, 0.0]};
    Object.defineProperty(navigator, 'getGamepads', {configurable: true, value: () => [window.doggedPad]}); }"""


PAD_DEAD_ZONE = 0.15  # the page's (services/ui/static/app.js), of a stick's throw, each axis


def pad_says(axis: float) -> float:
    """What the page says of one stick axis: 0 inside its dead zone, past it the throw from the zone's edge
    scaled to the whole range (as app.js's pollGamepad)."""
    if abs(axis) <= PAD_DEAD_ZONE:
        return 0.0
    return float(np.sign(axis) * min(1.0, (abs(axis) - PAD_DEAD_ZONE) / (1.0 - PAD_DEAD_ZONE)))


class StickPerson:
    """A scripted person at the page who knows ball seeking and drives with a gamepad stick: each tick it holds
    the stick where the page says the ball-seeking teacher's answer (up for forward, left for a left turn), as
    finely as a stick says it (steps of 1/127 of its throw: the step whose say is nearest, the stick centred
    when none is nearer than that). It teaches by degrees, as the program does; KeyboardPerson's keys are
    whole turns."""

    STEPS = 127

    def __init__(self, page, spaces):
        self.page, self.held = page, False
        self.policy = make_teacher("ballseek", spaces)
        low, high = (np.asarray(b, dtype=np.float64) for b in (spaces.output.low, spaces.output.high))
        self.mid, self.half = (low + high) / 2, (high - low) / 2
        self.says = np.array([pad_says(k / self.STEPS) for k in range(self.STEPS + 1)])  # each step's say
        page.evaluate(PAD_PLUGGED)

    def axes_for(self, x: np.ndarray) -> list[float]:
        """The pad's axes for the teacher's answer on x: centred where it has none."""
        y, _ = self.policy(x)
        if y is None:
            return [0.0, 0.0]
        fractions = np.clip((np.asarray(y) - self.mid) / self.half, -1, 1)
        forward, turn = (np.sign(f) * np.argmin(np.abs(self.says - abs(f))) / self.STEPS for f in fractions)
        return [float(-turn), float(-forward)]

    def drive(self, x, now: float) -> None:
        if x is not None:
            self.hold(self.axes_for(x))

    def hold(self, axes: list[float]) -> None:
        self.page.evaluate("(axes) => { window.doggedPad.axes = axes; }", axes)
        self.held = any(a != 0.0 for a in axes)

    def release(self) -> None:
        self.hold([0.0, 0.0])


class PageStage(LiveStage):
    """The ball-seeking protocol's stage where teaching is the person at the page driving with keys
    (LiveStage's teacher switch is never used): while teaching, every tick the person presses what the
    robot's newest input calls for; otherwise their hands are off the keys."""

    def __init__(self, run: LiveRun, rate: float, person: KeyboardPerson):
        super().__init__(run, rate)
        self.person = person

    def switch(self, on: bool) -> None:
        recorded = self.run.recorded[self.run.keys.input][-1:] if on else []
        newest = decoded(Input, *recorded[0][:2]) if recorded else None
        self.person.press(self.person.keys_for(newest.x) if newest is not None else set())
        self.teaching = on


def teach_click_to_bus(run: LiveRun, page, teacher: str, timeout: float = 5.0) -> float:
    """Clicks the page's Teach toggle of `teacher` (switched off) and returns the milliseconds from the
    click (the page's clock) to the first teacher command on the bus (its arrival here): the ears turned."""
    commands = run.recorded[run.keys.command]
    button = f'button.toggle[data-teacher="{teacher}"]'
    page.wait_for_selector(f"{button}:not(.on)", timeout=timeout * 1000)  # the page knows it is off
    seen = len(commands)
    page.click(button)
    clicked = page.evaluate("window.doggedStats.clicks.at(-1)[1]") / 1000.0  # the page's clock: the wall's

    def first_teacher():
        for key, raw, arrived in commands[seen:]:
            command = decoded(Command, key, raw)
            if command is not None and command.mode == "teacher":
                return arrived
        return None
    arrived = poll(first_teacher, timeout, 0.005)
    if arrived is None:
        raise TimeoutError(f"no teacher command within {timeout} s of clicking Teach for {teacher}")
    return 1000.0 * (arrived - clicked)
