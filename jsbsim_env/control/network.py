"""The actor network that flies: an observation window through one LSTM layer, then two ReLU
layers to the mean and standard deviation of a tanh-squashed Gaussian (the paper's Section 3.3).
Training adds the critics and the sampling around it (``training.networks``); flight takes tanh
of the mean (``jsbsim_env.control.policy``).
"""

from __future__ import annotations

import torch
from tensordict.nn import NormalParamExtractor
from torch import nn

from jsbsim_env.control.observation import ACTION_SIZE, OBS_SIZE


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


def mlp(inputs: int, hidden: int, outputs: int) -> nn.Sequential:
    """Two ReLU layers of ``hidden`` units, then a linear output (the actor's and the critics' heads)."""
    return nn.Sequential(nn.Linear(inputs, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU(),
                         nn.Linear(hidden, outputs))


class ActorNet(nn.Module):
    """Observation window -> (loc, scale) of the pre-tanh Gaussian."""

    def __init__(self, lstm_hidden: int = 64, mlp_hidden: int = 256, obs_size: int = OBS_SIZE,
                 action_size: int = ACTION_SIZE):
        super().__init__()
        self.encoder = LSTMEncoder(obs_size, lstm_hidden)
        self.head = mlp(lstm_hidden, mlp_hidden, 2 * action_size)
        # Scale through a softplus biased so that a zero input gives a standard deviation of 1,
        # bounded away from zero (TorchRL's usual choice for SAC).
        self.params = NormalParamExtractor(scale_mapping="biased_softplus_1", scale_lb=1e-4)

    def forward(self, window: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.params(self.head(self.encoder(window)))
