"""The simulated Aibo as a platform service.

DL side (dl/<instance>/...): with --input joints it is the platform of the mirroring task (input
the 18 joint positions); with --input camera its ticks are camera frames that perception turns
into the input (ball seeking); with --input phase its input is the gait clock (the walk level of
deploy/hierarchy.toml). It applies the arbitrator's commands (18 joint targets; --command move:
forward, turn walked by the gait; --command legs: 12 leg targets), reports what it applied, holds
still under the watchdog and lights its ears with the mode.
Robot side (robot/<name>/...): JPEG frames at the camera rate, the simulation clock, ground-truth
state; it takes a handler's joints and arena resets. Frames beside the input are numbered by their
own count, so perception can start another instance's ticks with them.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import zenoh

from bus_schema import ArenaReset, Clock, Frame, Handle, InstanceKeys, RobotKeys, RobotState, SpacesMessage, encode
from bus_schema.spaces import announced
from services.boxes.numbers import COUNT, POSITIVE_HZ, RATE_HZ, SECONDS
from services.boxes.platform import PlatformLoop, finish, run_ticks
from services.bus.config import add_bus_args, config_from_args
from services.bus.inbox import decode_or_reject
from services.bus.runtime import BoxRuntime
from services.perception.jpeg import encode_rgb
from services.platforms.aibo.camera import HEIGHT, WIDTH
from services.platforms.aibo.platform import COMMAND_MODES, AiboPlatform

STATE_HZ = 20.0


class AiboLoop(PlatformLoop):
    def __init__(self, box: BoxRuntime, robot_keys: RobotKeys, platform: AiboPlatform, input_mode: str,
                 camera_hz: float, latency_log=None):
        super().__init__(box, platform, latency_log)
        self.robot_keys, self.sim, self.input_mode = robot_keys, platform.sim, input_mode
        self.camera_period = 1.0 / camera_hz if camera_hz else None
        self.next_frame = 0.0
        self.next_state = 0.0
        self.frame_pub = box.sensor_publisher(robot_keys.camera, bulky=True)
        self.clock_pub = box.sensor_publisher(robot_keys.clock)
        self.state_pub = box.sensor_publisher(robot_keys.state, bulky=True)
        self.handle_mask = np.zeros(18)

    def publish_input(self):
        if self.input_mode != "camera":
            super().publish_input()
        else:  # the frame is the tick: perception answers it with the input
            self.publish_frame(self.next_tick())

    def after_tick(self):
        self.publish_robot_streams()

    def publish_frame(self, tick: int):
        jpeg = encode_rgb(self.sim.render_camera())
        self.frame_pub.put(encode(Frame(tick, time.time(), self.sim.sim_time, WIDTH, HEIGHT, jpeg)))
        self.counts["frames"] += 1

    def publish_robot_streams(self):
        now = self.sim.sim_time
        self.clock_pub.put(encode(Clock(now, time.time())))
        if self.input_mode != "camera" and self.camera_period and now >= self.next_frame:
            self.next_frame = max(self.next_frame + self.camera_period, now)
            self.publish_frame(self.counts["frames"] + 1)
        if now >= self.next_state:
            self.next_state = now + 1.0 / STATE_HZ
            self.state_pub.put(encode(self.robot_state()))

    def robot_state(self) -> RobotState:
        position, _ = self.sim.base_pose()
        nose, _ = self.sim.nose_pose()
        balls = {name: [float(v) for v in xyz] for name, xyz in self.sim.ball_positions().items()}
        colours = self.sim.ear_colours()
        return RobotState(self.sim.sim_time, np.array([position[0], position[1], self.sim.base_yaw()]), nose,
                          balls, self.sim.ear_mode or "", np.array(colours[0] if colours else (0, 0, 0, 0)))

    def show_mode(self, mode: str) -> None:
        self.sim.set_ear_mode(mode)

    def on_handle(self, key, raw):
        msg = decode_or_reject(Handle, raw, key, self.rejects, {"mask": 18, "q": 18})
        if msg is not None:
            self.handle_mask = msg.mask
            self.sim.set_handled(msg.mask.astype(bool), msg.q)
            self.counts["handled"] += 1

    def on_arena(self, key, raw):
        msg = decode_or_reject(ArenaReset, raw, key, self.rejects)
        if msg is None:
            return
        unknown = set(msg.balls) - set(self.sim.ball_positions())
        if unknown:
            self.rejects(key, ValueError(f"{key}: unknown balls {sorted(unknown)}"))
            return
        self.platform.reset(msg.seed)
        for name, xy in msg.balls.items():
            self.sim.hide_ball(name) if xy is None else self.sim.place_ball(name, xy)
        # a reset rebuilds the robot: what the bus had set must be set again
        self.sim.set_ear_mode(self.mode or None)
        self.sim.set_handled(self.handle_mask.astype(bool))
        self.next_frame = self.next_state = 0.0
        self.counts["resets"] += 1
        self.log.info("arena reset with seed %d, balls %s", msg.seed, msg.balls or "as seeded")

    def report(self):
        counters, state = super().report()
        state.update(sim_time=round(self.sim.sim_time, 3), ear_mode=self.sim.ear_mode or "")
        return counters, state


def main(conf: zenoh.Config, instance: str, name: str, robot: str, seed: int, command: str, input_mode: str,
         rate_hz: float, sim_hz: float, camera_hz: float, watchdog: float, max_ticks: int, gui: bool,
         latency_log: str | None = None, summary: str | None = None, command_from: str | None = None) -> int:
    box, robot_keys = BoxRuntime(conf, InstanceKeys(instance), "aibo", name), RobotKeys(robot)
    inputs = "phase" if input_mode == "phase" else "joints"
    with AiboPlatform(seed=seed, command=command, gui=gui, inputs=inputs) as aibo, box:
        loop = AiboLoop(box, robot_keys, aibo, input_mode, camera_hz, latency_log)
        robot_spaces = encode(SpacesMessage(announced(aibo.spaces, rate_hz).to_dict()))
        box.subscribe(robot_keys.handle, "handle")
        box.subscribe(robot_keys.arena, "arena")
        box.queryable(robot_keys.spaces, "robot_spaces")
        handlers = {"handle": loop.on_handle, "arena": loop.on_arena,
                    "robot_spaces": lambda key, query: query.reply(robot_keys.spaces, robot_spaces)}
        box.log.info("aibo %s: input %s, command %s, %s, camera %s Hz", robot, input_mode, command,
                     f"{rate_hz} Hz" if rate_hz else "lockstep", camera_hz)
        # with the camera as input, perception owns dl/<i>/spaces (its input, our output)
        spaces_key = "" if input_mode == "camera" else box.keys.spaces
        run_ticks(loop, handlers, rate_hz, sim_hz, watchdog, max_ticks, spaces_key, command_from)
        finish(loop, latency_log, summary)
    return 0


def arg_parser() -> argparse.ArgumentParser:
    """The one reading of `dogged run aibo`'s arguments (a profile's are read with it too)."""
    parser = argparse.ArgumentParser(prog="dogged run aibo", description=__doc__.splitlines()[0])
    parser.add_argument("--instance", default="main")
    parser.add_argument("--name", default="aibo")
    parser.add_argument("--robot", default="aibo", help="robot name: its streams are under robot/<name>/")
    parser.add_argument("--seed", type=COUNT, default=0, help="the same seed gives the same arena and run")
    parser.add_argument("--command", choices=COMMAND_MODES, default="joints")
    parser.add_argument("--input", choices=("joints", "camera", "phase"), default="joints", dest="input_mode")
    parser.add_argument("--rate", type=RATE_HZ, default=30.0, help="control rate in Hz, real time; 0 = lockstep")
    parser.add_argument("--sim-hz", type=POSITIVE_HZ, default=30.0, help="simulated ticks per second in lockstep")
    parser.add_argument("--camera-hz", type=RATE_HZ, default=15.0, help="frame rate beside the input (0: none)")
    parser.add_argument("--watchdog", type=SECONDS, default=0.5)
    parser.add_argument("--max-ticks", type=COUNT, default=0)
    parser.add_argument("--gui", action="store_true", help="PyBullet's GUI (needs a display)")
    parser.add_argument("--latency-log", default=None)
    parser.add_argument("--summary", default=None)
    parser.add_argument("--command-from", default=None, metavar="INSTANCE", help="obey a lower chained instance")
    add_bus_args(parser)
    return parser


def cli(argv=None) -> int:
    parser = arg_parser()
    a = parser.parse_args(argv)
    return main(config_from_args(a), a.instance, a.name, a.robot, a.seed, a.command, a.input_mode, a.rate, a.sim_hz,
                a.camera_hz, a.watchdog, a.max_ticks, a.gui, a.latency_log, a.summary, a.command_from)
