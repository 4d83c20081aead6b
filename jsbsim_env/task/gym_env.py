"""Gymnasium environment over the same task, registered in its versions (``jsbsim_env.task.versions``):
``SolarUAVAttitude-v0`` (the paper's task) and ``SolarUAVAttitude-v1`` (the task the shipped
controller trained on). Versions after the default (``versions.LATEST``) are candidates and
register in the ``candidates`` namespace (``gym.make("candidates/SolarUAVAttitude-v3")``), so that
gymnasium does not advise every user of the default to "upgrade" to one.

    >>> import gymnasium as gym, jsbsim_env
    >>> env = gym.make("SolarUAVAttitude-v1")
    >>> obs, info = env.reset(seed=0)
    >>> obs.shape, env.action_space.shape
    ((20,), (4,))

One aircraft, observation (20,) float32 (``jsbsim_env.control.observation`` gives every index,
unit and scale) and action (4,) float32 in [-1, 1] as described in ``jsbsim_env.task.attitude``;
``info`` carries every reward term, the termination reason and the true state. Pass
``config=TaskConfig(...)`` to ``gym.make`` to change the task, and ``aircraft=`` (a packaged
aircraft's name or a built aircraft's folder, ``aircraft.load_aircraft``) to fly the task on
another aircraft: ``gym.make("SolarUAVAttitude-v1", aircraft="builds/my_uav")``.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import ClassVar

import gymnasium as gym
import numpy as np

from jsbsim_env.control.observation import ACTION_SIZE
from jsbsim_env.task.attitude import AttitudeTask, TaskConfig


class SolarUAVAttitudeGymEnv(gym.Env):
    """The attitude-tracking task as a gymnasium environment (see ``jsbsim_env.task.attitude`` for the tables)."""

    metadata: ClassVar[dict] = {"render_modes": []}

    def __init__(self, config: TaskConfig | None = None, aircraft: str | Path | None = None):
        config = config or TaskConfig()
        if aircraft is not None:
            config = replace(config, core=replace(config.core, aircraft=str(aircraft)))
        self.task = AttitudeTask(config)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, shape=(self.task.config.observation_size,),
                                                dtype=np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, shape=(ACTION_SIZE,), dtype=np.float32)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        # Every draw of the episode comes from a seed taken from gymnasium's own generator, so a
        # reset without a seed continues the stream that the last seeded reset started.
        episode_seed = int(self.np_random.integers(2**63))
        obs, info = self.task.reset(episode_seed, **(options or {}))
        return obs, info

    def step(self, action):
        return self.task.step(np.asarray(action, dtype=np.float64))


ENV_ID = "SolarUAVAttitude-v0"  # the paper's task; jsbsim_env.task.versions lists every version


CANDIDATES_NAMESPACE = "candidates"


def gym_id(env_id: str) -> str:
    """The gymnasium id of the task version ``env_id``: itself up to the default version, in the
    ``candidates`` namespace after it."""
    from jsbsim_env.task.versions import LATEST, VERSIONS

    order = list(VERSIONS)
    return env_id if order.index(env_id) <= order.index(LATEST) else f"{CANDIDATES_NAMESPACE}/{env_id}"


def register() -> None:
    """Register every task version with gymnasium (done on ``import jsbsim_env``)."""
    from jsbsim_env.task.versions import VERSIONS

    for env_id, version in VERSIONS.items():
        if gym_id(env_id) not in gym.registry:
            gym.register(id=gym_id(env_id), entry_point="jsbsim_env.task.gym_env:SolarUAVAttitudeGymEnv",
                         max_episode_steps=None, kwargs={"config": version.task})
