"""The person at the page as a demonstrator: while they hold a key, a button or a gamepad stick,
their command is a teacher's output (teacher/<person>), it drives the robot and trains the learner.

A key held on one axis only (say, turning) is a partial teacher: the proposal's mask names that axis,
and the rest comes from the student. The page sends the person's command each time it changes and
every TELEOP_REFRESH_S while held; a command not refreshed for TELEOP_EXPIRE_S (a page closed, a
network gone) lets go, so a lost browser never keeps driving the robot.
"""
from __future__ import annotations

import logging
import time

import numpy as np

from bus_schema import Box, InstanceKeys, Proposal, encode
from services.bus.publishers import sensor_publisher

TELEOP_REFRESH_S = 0.1  # the page's heartbeat while a command is held (services/ui/static/app.js)
TELEOP_EXPIRE_S = 0.5


class Teleop:
    def __init__(self, session, keys: InstanceKeys, person: str, output: Box, log: logging.Logger):
        self.session, self.keys, self.person, self.log = session, keys, person, log
        self.low, self.high = np.asarray(output.low, dtype=np.float64), np.asarray(output.high, dtype=np.float64)
        self.pub = sensor_publisher(session, keys.proposal("teacher", person))
        self.token = None  # the teaching token, held while the person speaks
        self.y = self.mask = None
        self.newest_tick: int | None = None
        self.said_at = 0.0
        self.proposals = 0

    def set(self, fractions: list) -> None:
        """The person's command: per output a fraction of its range in [-1, 1] (1: its high end), or None."""
        spoken = np.array([f is not None for f in fractions])
        if not spoken.any():
            self.let_go()
            return
        f = np.array([0.0 if v is None else v for v in fractions])
        mid, half = (self.low + self.high) / 2, (self.high - self.low) / 2
        self.y, self.mask = mid + f * half, spoken.astype(np.float64)
        self.said_at = time.monotonic()
        if self.token is None:
            # the token first: the arbitrator takes a teacher's proposals only while it holds one
            self.token = self.session.liveliness().declare_token(self.keys.teaching(self.person))
            self.log.info("%s teleoperates", self.person)
        self.answer()  # at once, for the newest tick: a key press reaches the bus without waiting for an input

    def let_go(self) -> None:
        if self.token is not None:
            self.token.undeclare()
            self.token = None
            self.log.info("%s let go", self.person)
        self.y = self.mask = None

    def expire(self) -> None:
        if self.token is not None and time.monotonic() - self.said_at > TELEOP_EXPIRE_S:
            self.log.warning("%s's command was not refreshed for %.1f s: let go", self.person, TELEOP_EXPIRE_S)
            self.let_go()

    def on_tick(self, tick: int) -> None:
        """A new input: the person, while speaking, answers it as every teacher does."""
        self.newest_tick = tick
        if self.token is not None:
            self.answer()

    def answer(self) -> None:
        if self.y is None or self.newest_tick is None:
            return
        mask = None if self.mask.all() else self.mask
        self.pub.put(encode(Proposal(self.newest_tick, f"teacher/{self.person}", self.y, 1.0, mask)))
        self.proposals += 1

    def view(self) -> dict:
        return {"name": self.person, "active": self.token is not None, "proposals": self.proposals,
                "y": None if self.y is None else [round(v, 4) for v in self.y.tolist()],
                "mask": None if self.mask is None else self.mask.astype(int).tolist()}
