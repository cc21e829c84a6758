"""Any Gymnasium environment as a DL platform: the observation is the input, the output is the action.

    GymPlatform(env="Pendulum-v1", seed=0, **options)      # options go to gymnasium.make (g=9.81, ...)

An environment qualifies when its observation space is a Box and its action space a Box or a
Discrete. A Box action is the output as it is (its bounds, clipped). A Discrete(n) action is n
outputs in [0, 1], one per action: the largest is taken (ties: the first), and the platform reports
the one-hot of the action taken as what it applied (a teacher's choice is learned as one-hot: the
arbitrator reads `spaces.extra["choice"] == "largest"`). Input bounds are the environment's; where it
declares none (CartPole's velocities are unbounded), a table of the classic tasks gives them, else a
seeded random-policy probe (4x the largest value seen, at least 1); observations are clipped to them
and the clips counted. Names come from the same table (else obs0..., action0...).

Each call of `step` advances the environment one step of its own (the tick's `dt` is not the
environment's: Pendulum's step is 0.05 s whatever the loop's rate). An episode that ends (terminated
or truncated) resets by itself, seeded from the platform's seed and the episode's number, and
`outcome()` reports every step's reward and the running return for the bus (`dl/<i>/reward`,
`dl/<i>/episode`), never as an input. The watchdog's `hold` pauses the environment: a simulated
world waits for its agent rather than carrying on with an action nobody chose.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from bus_schema.spaces import Box, Spaces

UNBOUNDED = 1e6  # a bound at or past this (float32's max, inf) is no bound a learner can use
PROBE_STEPS, PROBE_MARGIN = 2000, 4.0

# names and missing bounds of the classic control tasks (gymnasium's docs for each environment)
KNOWN = {
    "Pendulum": {"inputs": ("cos_theta", "sin_theta", "theta_dot"), "outputs": ("torque",)},
    "CartPole": {"inputs": ("cart_position", "cart_velocity", "pole_angle", "pole_angular_velocity"),
                 "outputs": ("push_left", "push_right"), "bounds": {1: 5.0, 3: 10.0}},
    "MountainCarContinuous": {"inputs": ("position", "velocity"), "outputs": ("force",)},
    "MountainCar": {"inputs": ("position", "velocity"), "outputs": ("push_left", "no_push", "push_right")},
    "Acrobot": {"inputs": ("cos_theta1", "sin_theta1", "cos_theta2", "sin_theta2", "theta1_dot", "theta2_dot"),
                "outputs": ("torque_minus", "torque_zero", "torque_plus")},
}


class StepOutcome(NamedTuple):
    """What one environment step earned: the reward, the episode's return so far, and whether it ended."""
    episode: int
    step: int
    reward: float
    episode_return: float
    terminated: bool
    truncated: bool

    @property
    def done(self) -> bool:
        return self.terminated or self.truncated


def _known(env_id: str) -> dict:
    return KNOWN.get(env_id.split("-v")[0], {})


def _check_spaces(env, env_id: str):
    import gymnasium.spaces as gs
    obs, act = env.observation_space, env.action_space
    if not isinstance(obs, gs.Box):
        raise ValueError(f"env {env_id}: its observation space is {type(obs).__name__}; the gym platform takes a Box")
    if not isinstance(act, (gs.Box, gs.Discrete)):
        raise ValueError(f"env {env_id}: its action space is {type(act).__name__}; the gym platform takes a Box "
                         "or a Discrete")
    return obs, act


class GymPlatform:
    def __init__(self, env: str = "Pendulum-v1", seed: int = 0, reset_options: dict | None = None, **options):
        import gymnasium  # imported when asked for: the other platforms do without it
        if not isinstance(env, str) or not env:
            raise ValueError(f"env: expected a Gymnasium environment id such as 'Pendulum-v1', got {env!r}")
        if not isinstance(seed, int) or isinstance(seed, bool) or not 0 <= seed < 2 ** 31:
            raise ValueError(f"seed: expected an integer in 0..2^31-1, got {seed!r}")
        if reset_options is not None and not isinstance(reset_options, dict):
            raise ValueError(f"reset_options: expected a map, got {reset_options!r}")
        try:
            self._env = gymnasium.make(env, **options)
        except gymnasium.error.Error as err:
            raise ValueError(f"env: {err}") from None
        except TypeError as err:  # an option the environment does not take
            raise ValueError(f"env {env}: {err}; options are passed to gymnasium.make") from None
        self.env_id, self.seed, self.reset_options = env, seed, reset_options
        obs, act = _check_spaces(self._env, env)
        self._discrete = not hasattr(act, "low")
        known = _known(env)
        self._input_box = self._inputs(obs, known)
        self._output_box = self._outputs(act, known)
        extra = {"platform": "gym", "env": env, "max_episode_steps": self._env.spec.max_episode_steps}
        if self._discrete:
            extra["choice"] = "largest"
        self.spaces = Spaces(self._input_box, self._output_box, extra)
        self.clipped_inputs = 0
        self._closed = False
        self.reset(seed)

    def _inputs(self, obs, known: dict) -> Box:
        low, high = obs.low.astype(np.float64).ravel(), obs.high.astype(np.float64).ravel()
        table = known.get("bounds", {})
        unbounded = ~(np.isfinite(low) & np.isfinite(high) & (np.abs(low) < UNBOUNDED) & (np.abs(high) < UNBOUNDED))
        probed = self._probe() if any(i not in table for i in np.flatnonzero(unbounded)) else None
        for i in np.flatnonzero(unbounded):
            reach = table.get(int(i)) if int(i) in table else float(probed[i])
            low[i], high[i] = -reach, reach
        names = known.get("inputs")
        names = tuple(names) if names and len(names) == len(low) else tuple(f"obs{i}" for i in range(len(low)))
        return Box(tuple(low), tuple(high), names)

    def _probe(self) -> np.ndarray:
        """Per input, PROBE_MARGIN times the largest magnitude a seeded random policy reaches (at least 1)."""
        self._env.action_space.seed(self.seed)
        seen = np.abs(self._env.reset(seed=self.seed)[0].astype(np.float64).ravel())
        for _ in range(PROBE_STEPS):
            observation, _, terminated, truncated, _ = self._env.step(self._env.action_space.sample())
            seen = np.maximum(seen, np.abs(observation.astype(np.float64).ravel()))
            if terminated or truncated:
                self._env.reset()
        return np.maximum(PROBE_MARGIN * seen, 1.0)

    def _outputs(self, act, known: dict) -> Box:
        names = known.get("outputs")
        if self._discrete:
            n = int(act.n)
            names = tuple(names) if names and len(names) == n else tuple(f"action{i}" for i in range(n))
            return Box((0.0,) * n, (1.0,) * n, names)
        low, high = act.low.astype(np.float64).ravel(), act.high.astype(np.float64).ravel()
        if not (np.isfinite(low).all() and np.isfinite(high).all()):
            raise ValueError(f"env {self.env_id}: its action space is unbounded; the gym platform needs bounds "
                             "to keep every command inside them")
        names = tuple(names) if names and len(names) == len(low) else tuple(f"action{i}" for i in range(len(low)))
        return Box(tuple(low), tuple(high), names)

    # --- the Platform contract --------------------------------------------------------
    def reset(self, seed: int | None = None) -> np.ndarray:
        if seed is not None:
            self._base_seed = int(seed)
            self.episode = 0
        else:
            self.episode += 1
        self._begin()
        return self.observe()

    def _begin(self) -> None:
        observation, _ = self._env.reset(seed=self._base_seed + self.episode, options=self.reset_options)
        self._env.action_space.seed(self._base_seed + self.episode)
        self._step, self._return, self._outcome = 0, 0.0, None
        self._observe(observation)

    def _observe(self, observation) -> None:
        raw = np.asarray(observation, dtype=np.float64).ravel()
        box = self._input_box
        self._x = box.clip(raw)
        if not np.array_equal(self._x, raw):
            self.clipped_inputs += 1

    def observe(self) -> np.ndarray:
        return self._x.copy()

    def step(self, command: np.ndarray, dt: float) -> np.ndarray:
        applied = self._output_box.clip(np.asarray(command, dtype=np.float64))
        if self._discrete:
            action = int(np.argmax(applied))
            applied = np.zeros(self._output_box.dims)
            applied[action] = 1.0
        else:
            action = applied.astype(self._env.action_space.dtype).reshape(self._env.action_space.shape)
        observation, reward, terminated, truncated, _ = self._env.step(action)
        self._step += 1
        self._return += float(reward)
        outcome = StepOutcome(self.episode, self._step, float(reward), self._return, bool(terminated),
                              bool(truncated))
        if outcome.done:
            self.episode += 1
            self._begin()
        else:
            self._observe(observation)
        self._outcome = outcome
        return applied

    def outcome(self) -> StepOutcome | None:
        """The last step's outcome, once (None after a hold or when already taken)."""
        outcome, self._outcome = self._outcome, None
        return outcome

    def hold(self, dt: float) -> None:
        """The environment waits: nothing is stepped without an action chosen for it."""

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._env.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
