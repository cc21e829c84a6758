"""The gym platform's promises beyond the conformance suite: spaces from the environment (names, bounds
where it declares none), a Discrete action taken as the largest output and reported as one-hot, episodes
that reset by themselves with their reward reported, options passed through, and clear errors."""
import gymnasium
import numpy as np
import pytest

from services.platforms.gym import GymPlatform


def test_pendulum_spaces_are_the_environments_with_names():
    with GymPlatform("Pendulum-v1") as platform:
        spaces = platform.spaces
        assert spaces.input.names == ("cos_theta", "sin_theta", "theta_dot")
        assert spaces.input.low == (-1.0, -1.0, -8.0) and spaces.input.high == (1.0, 1.0, 8.0)
        assert spaces.output.names == ("torque",) and spaces.output.low == (-2.0,) and spaces.output.high == (2.0,)
        assert spaces.extra["env"] == "Pendulum-v1" and "choice" not in spaces.extra


def test_cartpole_gets_bounds_for_its_unbounded_velocities_and_one_output_per_action():
    with GymPlatform("CartPole-v1") as platform:
        spaces = platform.spaces
        assert np.isfinite(spaces.input.low).all() and np.isfinite(spaces.input.high).all()
        assert spaces.input.high[1] == 5.0 and spaces.input.high[3] == 10.0
        assert spaces.output.names == ("push_left", "push_right") and spaces.extra["choice"] == "largest"


def test_a_discrete_action_is_the_largest_output_reported_one_hot():
    with GymPlatform("Acrobot-v1") as platform:
        assert platform.step(np.array([0.2, 0.9, 0.1]), 0.02).tolist() == [0.0, 1.0, 0.0]
        assert platform.step(np.array([5.0, -3.0, 5.0]), 0.02).tolist() == [1.0, 0.0, 0.0]  # clipped, then a tie


def test_episodes_reset_by_themselves_and_report_their_return():
    with GymPlatform("CartPole-v1", seed=3) as platform:
        total, outcomes = 0.0, []
        while not outcomes or not outcomes[-1].done:
            platform.step(np.array([1.0, 0.0]), 0.02)  # always left: the pole falls within a few dozen steps
            outcomes.append(platform.outcome())
            total += outcomes[-1].reward
        assert platform.outcome() is None  # taken once
        assert outcomes[-1].episode == 0 and outcomes[-1].step == len(outcomes) and outcomes[-1].terminated
        assert outcomes[-1].episode_return == pytest.approx(total)
        second = platform.observe()  # the next episode, seeded from the platform's seed and its number
        assert np.array_equal(second, gymnasium.make("CartPole-v1").reset(seed=3 + 1)[0].astype(np.float64))
        platform.step(np.array([1.0, 0.0]), 0.02)
        assert platform.outcome().episode == 1 and platform.outcome() is None


def test_hold_pauses_the_environment():
    with GymPlatform("Pendulum-v1", seed=1) as platform:
        before = platform.observe()
        for _ in range(10):
            platform.hold(0.02)
        assert np.array_equal(platform.observe(), before) and platform.outcome() is None


def test_options_pass_through_to_gymnasium_make():
    with GymPlatform("Pendulum-v1", g=0.0) as weightless:
        weightless.reset(seed=0)
        start = weightless.observe()
        weightless.step(np.zeros(1), 0.02)  # no gravity, no torque: the pendulum keeps its rate
        assert weightless.observe()[2] == pytest.approx(start[2], abs=1e-6)


@pytest.mark.parametrize(("params", "message"), [
    ({"env": "NoSuchEnv-v0"}, "env: "),
    ({"env": "Pendulum-v1", "gravity_of_mars": 3.7}, "options are passed to gymnasium.make"),
    ({"env": "Pendulum-v1", "seed": -1}, "seed: expected an integer"),
    ({"env": "Pendulum-v1", "reset_options": 3}, "reset_options: expected a map"),
    ({"env": "Blackjack-v1"}, "observation space is Tuple"),
])
def test_bad_parameters_are_refused_naming_them(params, message):
    with pytest.raises(ValueError, match=message):
        GymPlatform(**params)
