"""The UI's side of the bus: one thread, on the ui box's runtime (its session, inbox and status).

It listens (commands, proposals, status and liveliness of every service, the robot's camera, the
instance's inputs) and keeps a view the page is sent ten times a second; it acts for the
person (teach switches, teleoperation as a teacher, learner swap, arena reset). Zenoh callbacks only
append to the inbox; the page's requests come in through the same inbox, so one thread decodes,
validates and acts. What it has for the page goes out through `emit(kind, payload)`, which must
not block (the server hands it to its event loop).
"""
from __future__ import annotations

import collections
import math
import re
import struct
import threading
import time

import numpy as np
import zenoh

from bus_schema import (ArenaReset, Command, Episode, Frame, Input, Proposal, RecordSwitch, Reward,
                        RobotKeys, Spaces, Status, TeachSwitch, encode, is_name)
from bus_schema.keys import EVERY_ALIVE, EVERY_STATUS
from services.bus.inbox import decode_or_reject
from services.bus.control import ask_supervisor, running_profile
from services.bus.runtime import BoxRuntime
from services.ui.teleop import Teleop

VIEW_PERIOD_S = 0.1  # the page's view of the system, ten times a second
SERIES_HZ = 20  # points of the confidence / error plot per second at most
FRAME_HEADER = struct.Struct("<qd")  # tick, stamp: before each JPEG sent to the page
MAX_SERVICES = 256  # a bus flooded with made-up tokens does not grow the page without bound
EPISODES_SHOWN = 10  # a task's last episodes on the page (their return and who drove them)
_RATE = re.compile(r"^[a-z0-9_]{1,40}$")  # a counter's name, as the page shows it


class Bridge:
    def __init__(self, box: BoxRuntime, robot: str, person: str, spaces: Spaces, emit):
        self.box, self.session, self.keys, self.robot = box, box.session, box.keys, RobotKeys(robot)
        self.spaces, self.emit, self.log = spaces, emit, box.log
        self.inbox, self.rejects, self.counts = box.inbox, box.rejects, box.counts
        self.teleop = Teleop(box.session, self.keys, person, spaces.output, box.log)
        self.teach_pub = box.lossless_publisher(self.keys.teach)
        self.arena_pub = box.lossless_publisher(self.robot.arena)
        self.record_pub = box.lossless_publisher(self.keys.record)
        self.latest: dict = {}  # the newest command, as the page shows it
        self.task: dict = {}  # a task's reward (gym): the episode under way and the last ones ended
        self.learner_y: collections.OrderedDict[int, np.ndarray] = collections.OrderedDict()
        self.series: list = []  # new plot points since the last view
        self.services: dict[str, dict] = {}  # "instance/role/name" -> alive, rates, state
        self.t0, self._next_point, self._next_view = time.monotonic(), 0.0, 0.0
        self._half_range = np.maximum((np.asarray(spaces.output.high) - np.asarray(spaces.output.low)) / 2, 1e-12)
        self.url = ""  # where the page is served, once it is
        self.server_counts = lambda: {}  # the server's own (pages open, requests refused), for the status

    # --- wiring ---------------------------------------------------------------------------------
    def declare(self) -> None:
        """Called on the main thread, before `run`'s daemon thread starts (the runtime refuses another
        thread, and says why)."""
        for key, tag in ((self.keys.command, "command"), (self.keys.proposal("learner", "*"), "learner"),
                         (self.keys.input, "input"), (EVERY_STATUS, "status"), (self.robot.camera, "frame"),
                         (self.keys.reward, "reward"), (self.keys.episode, "episode")):
            self.box.subscribe(key, tag)
        self.box.subscribe_alive(EVERY_ALIVE, "alive")

    def request(self, op: str, fields: dict, reply) -> None:
        """From the server's thread: a checked page request; `reply(text, ok)` answers that page."""
        self.inbox.put(("page", op, (fields, reply), None))

    def run(self) -> None:
        """The bus thread's loop, until the box is stopped (its declarations end with the runtime)."""
        handlers = {"command": self.on_command, "learner": self.on_learner, "input": self.on_input,
                    "status": self.on_status, "frame": self.on_frame, "alive": self.on_alive,
                    "reward": self.on_reward, "episode": self.on_episode}
        try:
            for batch in self.box.batches(0.02, self.report):
                for tag, key, raw, kind in batch:
                    if tag == "page":
                        self.on_page(key, *raw)
                    else:
                        handlers[tag](key, raw, kind)
                self.teleop.expire()
                self.maybe_view()
        finally:  # however it ends: the person's teaching is let go
            self.teleop.let_go()

    # --- what the bus says ------------------------------------------------------------------------
    def on_command(self, key, raw, _):
        msg = decode_or_reject(Command, raw, key, self.rejects, {"y": self.spaces.output.dims})
        if msg is None:
            return
        self.counts["commands"] += 1
        self.latest = {"tick": msg.tick, "mode": msg.mode, "source": msg.source,
                       "confidence": round(msg.confidence, 4), "y": [round(v, 4) for v in msg.y.tolist()]}
        now = time.monotonic()
        if now < self._next_point:
            return
        self._next_point = now + 1.0 / SERIES_HZ
        learned = self.learner_y.get(msg.tick)
        error = None  # the student against the teacher, while a teacher speaks (RMS over half ranges)
        if msg.mode == "teacher" and learned is not None:
            error = round(float(np.sqrt(np.mean(((learned - msg.y) / self._half_range) ** 2))), 4)
        self.series.append([round(now - self.t0, 3), round(msg.confidence, 4), error, msg.mode])

    def on_learner(self, key, raw, _):
        msg = decode_or_reject(Proposal, raw, key, self.rejects, {"y": self.spaces.output.dims})
        if msg is not None and msg.y is not None:
            self.learner_y[msg.tick] = msg.y
            while len(self.learner_y) > 256:
                self.learner_y.popitem(last=False)

    def on_input(self, key, raw, _):
        msg = decode_or_reject(Input, raw, key, self.rejects, {"x": self.spaces.input.dims})
        if msg is not None:
            self.teleop.on_tick(msg.tick)

    def on_reward(self, key, raw, _):
        msg = decode_or_reject(Reward, raw, key, self.rejects)
        if msg is not None:
            self.task.update(episode=msg.episode, step=msg.step, episode_return=round(msg.episode_return, 3))

    def on_episode(self, key, raw, _):
        msg = decode_or_reject(Episode, raw, key, self.rejects)
        if msg is not None:
            ended = {"episode": msg.episode, "steps": msg.steps, "episode_return": round(msg.episode_return, 3),
                     "terminated": msg.terminated, "modes": msg.modes}
            self.task["ended"] = (self.task.get("ended", []) + [ended])[-EPISODES_SHOWN:]

    def on_status(self, key, raw, _):
        msg = decode_or_reject(Status, raw, key, self.rejects)
        if msg is None or not self._named(key, key.split("/")[1], msg.role, msg.name):
            return
        instance = key.split("/")[1]
        entry = self.services.setdefault(f"{instance}/{msg.role}/{msg.name}", {"alive": False})
        rates = msg.state.get("rates", {})
        if msg.role == "recorder":
            entry["recording"] = msg.state.get("recording") is not False
        entry.update(host=str(msg.state.get("host", ""))[:64],
                     rates={k: v for k, v in list(rates.items())[:16] if isinstance(k, str) and _RATE.match(k)
                            and isinstance(v, (int, float)) and math.isfinite(v)}
                     if isinstance(rates, dict) else {})

    def on_alive(self, key, _raw, kind):
        parts = key.split("/")  # dl/<instance>/alive/<role>/<name>
        if len(parts) != 5:
            return
        instance, role, name = parts[1], parts[3], parts[4]
        if not self._named(key, instance, role, name):
            return
        if role in ("teaching", "commanding"):
            role = f"{role}-token"
        entry = self.services.setdefault(f"{instance}/{role}/{name}", {"alive": False})
        entry["alive"] = kind == zenoh.SampleKind.PUT

    def _named(self, key: str, instance: str, role: str, name: str) -> bool:
        """Names the page shows are the bus's checked names (a key may hold other characters)."""
        known = any(f"{instance}/{r}/{name}" in self.services for r in (role, f"{role}-token"))
        if all(is_name(n) for n in (instance, role, name)) and (known or len(self.services) < MAX_SERVICES):
            return True
        self.rejects(key, ValueError(f"{key[:120]!r}: not instance/role/name of checked names, or more than "
                                     f"{MAX_SERVICES} services"))
        return False

    def on_frame(self, key, raw, _):
        msg = decode_or_reject(Frame, raw, key, self.rejects)
        if msg is not None:
            self.counts["frames"] += 1
            self.emit("frame", FRAME_HEADER.pack(msg.tick, msg.stamp) + msg.jpeg)

    # --- what the page asks -------------------------------------------------------------------------
    def on_page(self, op: str, fields: dict, reply) -> None:
        self.counts[f"page_{op}"] += 1
        if op == "teach":
            self.teach_pub.put(encode(TeachSwitch(fields["teacher"], fields["on"])))
            reply(f"teaching {'on' if fields['on'] else 'off'}: {fields['teacher'] or 'every teacher'}", True)
        elif op == "teleop":
            self.teleop.set(fields["y"])
        elif op == "record":
            self.record_pub.put(encode(RecordSwitch("", fields["on"])))
            reply(f"recording {'resumed' if fields['on'] else 'paused'}", True)
        elif op == "arena":
            self.arena_pub.put(encode(ArenaReset(fields["seed"], fields["balls"])))
            reply(f"arena {fields['seed']} asked", True)
        elif op == "swap":
            # the supervisor's answer takes up to minutes (a learner retrained): asked off this thread
            threading.Thread(target=self._swap, args=(fields["service"], fields["spec"], reply), daemon=True).start()

    def _swap(self, service: str, spec: str, reply) -> None:
        profile, problem = running_profile(self.session)
        answer = None
        if profile is not None:
            answer, problem = ask_supervisor(self.session, profile, "swap", f"service={service};spec={spec}", 180.0)
        reply(problem, False) if answer is None else reply(answer.text, answer.ok)

    def report(self) -> tuple[dict, dict]:
        return (dict(self.server_counts(), teleop_proposals=self.teleop.proposals),
                {"url": self.url, "person": self.teleop.person, "teleoperating": self.teleop.token is not None})

    # --- the page's view ------------------------------------------------------------------------------
    def maybe_view(self) -> None:
        now = time.monotonic()
        if now < self._next_view:
            return
        self._next_view = now + VIEW_PERIOD_S
        mine = f"{self.keys.instance}/"
        teachers = sorted({key.split("/")[2] for key, e in self.services.items()
                           if key.startswith(mine) and key.split("/")[1] == "teacher" and e["alive"]})
        teaching = sorted(key.split("/")[2] for key, e in self.services.items()
                          if key.startswith(mine) and key.split("/")[1] == "teaching-token" and e["alive"])
        services = [{"instance": key.split("/")[0], "role": key.split("/")[1], "name": key.split("/")[2],
                     "alive": e["alive"], "rates": e.get("rates", {}), "host": e.get("host", ""),
                     **({"recording": e["recording"]} if "recording" in e else {})}
                    for key, e in sorted(self.services.items()) if not key.split("/")[1].endswith("-token")]
        self.emit("view", {"type": "view", "command": self.latest, "series": self.series, "teachers": teachers,
                           "teaching": teaching, "services": services, "task": self.task,
                           "person": self.teleop.view(), "rejected": self.rejects.total})
        self.series = []
