"""Recurrent actor and critics of SPEC section 3.

Both read the last ``window`` observations, oldest first, through one LSTM layer (64 units) and
continue from its last output: the actor with two 256-unit ReLU layers to the mean and standard
deviation of a tanh-squashed Gaussian, each critic by concatenating the action and two 256-unit
ReLU layers to Q. The actor and the two critics each have their own LSTM.

Beyond the paper, the critics can instead read the critics' state, which only a simulation has
(``StateCriticNet``): an asymmetric actor-critic, whose actor still sees only what it will see in flight.
"""

from __future__ import annotations

import torch
from tensordict.nn import NormalParamExtractor, TensorDictModule
from torch import nn
from torchrl.modules import ProbabilisticActor, TanhNormal

from jsbsim_env.task import ACTION_SIZE, OBS_SIZE


class LSTMEncoder(nn.Module):
    """(..., window, obs) -> (..., hidden): the LSTM's output after the newest observation."""

    def __init__(self, obs_size: int, hidden: int):
        super().__init__()
        self.lstm = nn.LSTM(obs_size, hidden, batch_first=True)

    def forward(self, window: torch.Tensor) -> torch.Tensor:
        lead = window.shape[:-2]
        x = window.reshape(-1, *window.shape[-2:])
        out, _ = self.lstm(x)
        return out[:, -1].reshape(*lead, -1)


def _mlp(inputs: int, hidden: int, outputs: int) -> nn.Sequential:
    return nn.Sequential(nn.Linear(inputs, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU(),
                         nn.Linear(hidden, outputs))


class ActorNet(nn.Module):
    """Observation window -> (loc, scale) of the pre-tanh Gaussian."""

    def __init__(self, lstm_hidden: int = 64, mlp_hidden: int = 256, obs_size: int = OBS_SIZE,
                 action_size: int = ACTION_SIZE, initial_std: float = 1.0):
        super().__init__()
        self.encoder = LSTMEncoder(obs_size, lstm_hidden)
        self.head = _mlp(lstm_hidden, mlp_hidden, 2 * action_size)
        # Scale through a softplus biased so that a zero input gives ``initial_std``, bounded away
        # from zero (TorchRL's usual choice for SAC).
        self.params = NormalParamExtractor(scale_mapping=f"biased_softplus_{initial_std:g}", scale_lb=1e-4)

    def forward(self, window: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.params(self.head(self.encoder(window)))


class CriticNet(nn.Module):
    """(observation window, action) -> Q."""

    def __init__(self, lstm_hidden: int = 64, mlp_hidden: int = 256, obs_size: int = OBS_SIZE,
                 action_size: int = ACTION_SIZE):
        super().__init__()
        self.encoder = LSTMEncoder(obs_size, lstm_hidden)
        self.head = _mlp(lstm_hidden + action_size, mlp_hidden, 1)

    def forward(self, window: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        return self.head(torch.cat([self.encoder(window), action], dim=-1))


class StateCriticNet(nn.Module):
    """(critic state, action) -> Q with two 256-unit layers and no memory: for the critics' state
    (``task.AttitudeTaskBatch.critic_states``), which is Markov by construction. ``encoder`` is the
    identity so that it has the recurrent critic's interface."""

    def __init__(self, state_size: int, mlp_hidden: int = 256, action_size: int = ACTION_SIZE):
        super().__init__()
        self.encoder = nn.Identity()
        self.head = _mlp(state_size + action_size, mlp_hidden, 1)

    def forward(self, state: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        return self.head(torch.cat([state, action], dim=-1))


def make_actor(lstm_hidden: int = 64, mlp_hidden: int = 256, action_spec=None,
               initial_std: float = 1.0, obs_size: int = OBS_SIZE) -> ProbabilisticActor:
    """The SAC actor: ``observation`` -> ``action`` (in [-1, 1]) with ``loc``/``scale``."""
    module = TensorDictModule(ActorNet(lstm_hidden, mlp_hidden, obs_size=obs_size, initial_std=initial_std),
                              in_keys=["observation"], out_keys=["loc", "scale"])
    return ProbabilisticActor(
        module, in_keys=["loc", "scale"], spec=action_spec, distribution_class=TanhNormal,
        distribution_kwargs={"low": -1.0, "high": 1.0}, return_log_prob=False,
    )


def make_critic(lstm_hidden: int = 64, mlp_hidden: int = 256, obs_size: int = OBS_SIZE) -> TensorDictModule:
    """One Q network: (``observation``, ``action``) -> ``state_action_value``."""
    return TensorDictModule(CriticNet(lstm_hidden, mlp_hidden, obs_size=obs_size), in_keys=["observation", "action"],
                            out_keys=["state_action_value"])
