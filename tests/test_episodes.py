"""The platform box puts a task's reward on its own keys (fake bus): one Reward per step, one Episode per
episode with the steps each command mode drove, nothing for a platform without a reward."""
import numpy as np

from bus_schema import Command, Episode, InstanceKeys, Reward, decode, encode
from services.boxes.platform import PlatformLoop
from services.platforms.gym import GymPlatform
from services.platforms.point import PointPlatform
from tests.fakebus import FakeSession, fake_box

KEYS = InstanceKeys("main")


def drive(platform, modes: list[str]) -> FakeSession:
    bus = FakeSession()
    loop = PlatformLoop(fake_box("platform", "test", bus=bus), platform)
    for mode in modes:
        loop.publish_input()
        loop.on_command(KEYS.command, encode(Command(loop.tick, 0.0, np.array([1.0, 0.0]), mode, "x/y", 1.0)))
        loop.advance(0.02, watchdog=10.0)
    return bus


def test_each_step_its_reward_and_each_episode_who_drove_it():
    with GymPlatform("CartPole-v1", seed=0) as platform:  # pushed left for ever: the pole falls in ~10 steps
        bus = drive(platform, ["teacher"] * 5 + ["student"] * 30)
    rewards = [decode(Reward, raw, KEYS.reward) for raw in bus.on(KEYS.reward)]
    episodes = [decode(Episode, raw, KEYS.episode) for raw in bus.on(KEYS.episode)]
    assert len(rewards) == 35 and [r.tick for r in rewards] == list(range(1, 36))
    first = episodes[0]
    assert first.episode == 0 and first.terminated and first.modes == {"teacher": 5, "student": first.steps - 5}
    assert first.episode_return == sum(r.reward for r in rewards[:first.steps])
    assert rewards[first.steps - 1].done and rewards[first.steps].episode == 1 and rewards[first.steps].step == 1


def test_a_platform_without_a_reward_publishes_none():
    bus = drive(PointPlatform(dims=2), ["student"] * 5)
    assert bus.on(KEYS.reward) == [] and bus.on(KEYS.episode) == []
