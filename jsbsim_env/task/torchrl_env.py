"""TorchRL environment: N aircraft in one process, batched along the first dimension.

``SolarUAVAttitudeEnv`` is the plain environment (the observation of ``jsbsim_env.control.observation``,
one step per control interval); ``make_env`` adds the training transforms: the observation window
(the paper's 8 steps, Section 3.3), a step counter and the episode reward.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import Compose, EnvBase, RewardSum, StepCounter, TransformedEnv
from torchrl.envs.transforms import CatFrames, UnsqueezeTransform

from jsbsim_env.control.observation import ACTION_SIZE, ActionError
from jsbsim_env.control.stack import StackSettings
from jsbsim_env.task.attitude import (
    ACHIEVED_INDEX,
    PRIVILEGED_SIZE,
    REWARD_TERMS,
    AttitudeTaskBatch,
    TaskConfig,
    check_num_envs,
)

OBSERVATION_WINDOW = StackSettings().window_steps  # the paper's 8 (Section 3.3): the policy sees the last 8


def episode_seed(base_seed: int, env_index: int, episode: int) -> int:
    """The seed of one episode of one of the batched aircraft (independent streams)."""
    return int(np.random.SeedSequence([base_seed, env_index, episode]).generate_state(1, np.uint64)[0])


class SolarUAVAttitudeEnv(EnvBase):
    """Attitude tracking for the solar UAV, ``num_envs`` aircraft stepped together.

    Keys: ``observation`` (num_envs, 20) float32, ``action`` (num_envs, 4) in [-1, 1],
    ``reward`` (num_envs, 1), ``done``/``terminated``/``truncated`` (num_envs, 1), and
    ``reward_terms`` (num_envs, 4): the penalties of ``task.REWARD_TERMS``, with
    ``reward = 1 - reward_terms.sum(-1)``, and ``achieved`` (num_envs, 4): the true roll, pitch
    (rad), V_eas (m/s) and sideslip (rad) the reward was computed from (``task.ACHIEVED_INDEX``),
    which lets a learner recompute the reward for another goal. Where some episodes' throttle is
    flown by a speed hold (``TaskConfig.external_throttle``), ``speed_free`` (num_envs, 1) marks them:
    their reward has no airspeed term and their EAS goal is not a goal to relabel. With
    ``privileged``, ``privileged`` (num_envs, ``PRIVILEGED_SIZE``) holds what the aircraft cannot
    measure (``AttitudeTaskBatch.privileged``), for an asymmetric critic. With ``teacher`` (an LQI's
    name, ``jsbsim_env.control.teacher``), ``teacher_action`` (num_envs, 4) holds that LQI's action
    on each observation, flown in the shadow of the policy: a label to distil, never an input.
    """

    batch_locked = True

    def __init__(self, num_envs: int = 8, config: TaskConfig | None = None, seed: int = 0, privileged: bool = False,
                 teacher: str = ""):
        num_envs = check_num_envs(num_envs)  # before TorchRL builds a batch of it
        # The simulation runs on the CPU; collectors move the data to a training device.
        super().__init__(device="cpu", batch_size=torch.Size([num_envs]))
        self.num_envs = num_envs
        self.batch = AttitudeTaskBatch(num_envs, config, teacher)
        obs_size = self.batch.config.observation_size
        self._episodes = np.zeros(num_envs, dtype=np.int64)
        self._base_seed = int(seed)
        n = (num_envs,)
        specs = {"observation": Unbounded(shape=(*n, obs_size), dtype=torch.float32),
                 "reward_terms": Unbounded(shape=(*n, len(REWARD_TERMS)), dtype=torch.float32),
                 "achieved": Unbounded(shape=(*n, len(ACHIEVED_INDEX)), dtype=torch.float32)}
        self._speed_free = self.batch.config.external_throttle > 0.0
        if self._speed_free:
            specs["speed_free"] = Categorical(2, shape=(*n, 1), dtype=torch.bool)
        self._privileged = bool(privileged)
        if self._privileged:
            specs["privileged"] = Unbounded(shape=(*n, PRIVILEGED_SIZE), dtype=torch.float32)
        self._teacher = bool(teacher)
        if self._teacher:
            specs["teacher_action"] = Bounded(low=-1.0, high=1.0, shape=(*n, ACTION_SIZE), dtype=torch.float32)
        self.observation_spec = Composite(specs, shape=n)
        self.action_spec = Bounded(low=-1.0, high=1.0, shape=(*n, ACTION_SIZE), dtype=torch.float32)
        self.reward_spec = Unbounded(shape=(*n, 1), dtype=torch.float32)
        self.done_spec = Composite(
            done=Categorical(2, shape=(*n, 1), dtype=torch.bool),
            terminated=Categorical(2, shape=(*n, 1), dtype=torch.bool),
            truncated=Categorical(2, shape=(*n, 1), dtype=torch.bool),
            shape=n,
        )
        self._obs = np.zeros((num_envs, obs_size), dtype=np.float32)
        self._terms = np.zeros((num_envs, len(REWARD_TERMS)), dtype=np.float32)
        self._achieved = np.zeros((num_envs, len(ACHIEVED_INDEX)), dtype=np.float32)
        self.last_codes = np.zeros(num_envs, dtype=np.int64)  # core.TERMINATION_CAUSES of the last step

    def _set_seed(self, seed: int | None) -> None:
        self._base_seed = int(seed) if seed is not None else int(np.random.SeedSequence().entropy % 2**31)
        self._episodes[:] = 0

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs) -> TensorDictBase:
        mask = None
        if tensordict is not None and "_reset" in tensordict.keys():  # noqa: SIM118 (TensorDict membership needs keys())
            mask = tensordict["_reset"].reshape(self.num_envs).cpu().numpy()
        for i in range(self.num_envs):
            if mask is not None and not mask[i]:
                continue
            self._obs[i] = self.batch.reset_one(i, episode_seed(self._base_seed, i, int(self._episodes[i])))
            self._episodes[i] += 1
            self._terms[i] = 0.0
            self._achieved[i] = [self.batch.states[i][k] for k in ACHIEVED_INDEX]
        out = self._output(np.zeros(self.num_envs), np.zeros(self.num_envs, bool), np.zeros(self.num_envs, bool))
        del out["reward"]
        return out

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        action = tensordict.get("action", None)
        if action is None:
            raise ActionError(f"the TensorDict given to step() has no 'action' entry (num_envs x {ACTION_SIZE} "
                              f"actions in [-1, 1]); its keys: {sorted(map(str, tensordict.keys()))}")
        obs, terms, terminated, truncated, codes = self.batch.step(action.detach().cpu().numpy())
        self._obs[:] = obs
        self._terms[:] = terms[:, :4]
        # A terminated aircraft's state can be non-finite; its reward is 0 whatever the goal.
        self._achieved[:] = np.nan_to_num([[s[k] for k in ACHIEVED_INDEX] for s in self.batch.states])
        self.last_codes = codes
        return self._output(terms[:, 4], terminated, truncated)

    def _output(self, rewards, terminated, truncated) -> TensorDictBase:
        n = self.num_envs
        terminated_t = torch.from_numpy(np.asarray(terminated, dtype=bool)).reshape(n, 1)
        truncated_t = torch.from_numpy(np.asarray(truncated, dtype=bool)).reshape(n, 1)
        # Fresh CPU tensors of the spec's shapes and dtypes: the unchecked constructor is safe here
        # and saves a third of TorchRL's per-step overhead; on the env's device, TorchRL skips a copy.
        values = {"observation": torch.from_numpy(self._obs.copy()),
                  "reward_terms": torch.from_numpy(self._terms.copy()),
                  "achieved": torch.from_numpy(self._achieved.copy()),
                  "reward": torch.from_numpy(np.asarray(rewards, dtype=np.float32)).reshape(n, 1),
                  "terminated": terminated_t, "truncated": truncated_t, "done": terminated_t | truncated_t}
        if self._speed_free:
            values["speed_free"] = torch.tensor(self.batch.external_throttle).reshape(n, 1)
        if self._privileged:
            values["privileged"] = torch.from_numpy(self.batch.privileged())
        if self._teacher:
            values["teacher_action"] = torch.from_numpy(self.batch.teacher_actions())
        return TensorDict._new_unsafe(values, batch_size=self.batch_size, device=self.device)


def make_env(num_envs: int = 8, config: TaskConfig | None = None, seed: int = 0,
             window: int = OBSERVATION_WINDOW, privileged: bool = False, aircraft=None,
             teacher: str = "") -> TransformedEnv:
    """The training environment: the 8-step observation window (``observation`` becomes
    (num_envs, window, 20), oldest first), a step counter and the episode reward sum. ``num_envs``
    and ``window`` must be whole numbers >= 1 (the window at most 64, as a policy file's);
    ``privileged`` adds the ``privileged`` entry (the present step's, no window); ``aircraft``
    (a name or a built aircraft's folder) flies the task on that aircraft instead of ``config``'s;
    ``teacher`` adds the ``teacher_action`` entry (``SolarUAVAttitudeEnv``)."""
    num_envs = check_num_envs(num_envs)
    if aircraft is not None:
        config = config or TaskConfig()
        config = replace(config, core=replace(config.core, aircraft=str(aircraft)))
    try:
        StackSettings(window_steps=window)
    except ValueError:
        raise ValueError(f"window must be a whole number of steps in [1, 64], got {window!r}") from None
    env = SolarUAVAttitudeEnv(num_envs, config, seed, privileged, teacher)
    return TransformedEnv(env, Compose(
        UnsqueezeTransform(dim=-2, in_keys=["observation"], out_keys=["observation"]),
        CatFrames(N=window, dim=-2, in_keys=["observation"], out_keys=["observation"]),
        StepCounter(),
        RewardSum(),
    ))
