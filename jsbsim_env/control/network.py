"""The actor network that flies: an observation window through an encoder, then two ReLU layers to
the mean and standard deviation of a tanh-squashed Gaussian. The paper's encoder (Section 3.3) is
one LSTM layer; ``ENCODERS`` also offers a GRU layer and a windowed MLP (the whole window,
flattened, through one ReLU layer), for comparing architectures at the same budget. Training adds
the critics and the sampling around it (``training.networks``); flight takes tanh of the mean
(``jsbsim_env.control.policy``).
"""

from __future__ import annotations

import math

import torch
from tensordict.nn import NormalParamExtractor
from torch import nn

from jsbsim_env.control.observation import ACTION_SIZE, OBS_SIZE


class RecurrentEncoder(nn.Module):
    """(..., window, obs) -> (..., hidden): the output of one LSTM or GRU layer (``kind``) after the
    newest observation. The layer is the module's attribute of that name (``encoder.lstm.*`` in a
    policy file's weights, as before there were other kinds)."""

    def __init__(self, kind: str, obs_size: int, hidden: int):
        super().__init__()
        self.kind = kind
        self.add_module(kind, {"lstm": nn.LSTM, "gru": nn.GRU}[kind](obs_size, hidden, batch_first=True))

    def forward(self, window: torch.Tensor) -> torch.Tensor:
        lead = window.shape[:-2]
        x = window.reshape(-1, *window.shape[-2:])
        out, _ = getattr(self, self.kind)(x)
        return out[:, -1].reshape(*lead, -1)


class WindowMLPEncoder(nn.Module):
    """(..., window, obs) -> (..., hidden): the window flattened (oldest first) through one ReLU layer."""

    def __init__(self, obs_size: int, hidden: int, window: int):
        super().__init__()
        self.window = window
        self.layer = nn.Linear(window * obs_size, hidden)

    def forward(self, window: torch.Tensor) -> torch.Tensor:
        if window.shape[-2] != self.window:
            raise ValueError(f"the window MLP reads windows of {self.window} observations, got {window.shape[-2]}")
        return torch.relu(self.layer(window.flatten(-2)))


ENCODERS = ("lstm", "gru", "mlp")


def make_encoder(kind: str, obs_size: int, hidden: int, window: int) -> nn.Module:
    """The encoder ``kind`` (one of ``ENCODERS``) of ``hidden`` units over windows of ``window``."""
    if kind in ("lstm", "gru"):
        return RecurrentEncoder(kind, obs_size, hidden)
    if kind == "mlp":
        return WindowMLPEncoder(obs_size, hidden, window)
    raise ValueError(f"encoder must be one of {', '.join(ENCODERS)}, got {kind!r}")


def encoder_inputs(state: dict, kind: str, window: int) -> int:
    """The observation size an actor's state dict (``ActorNet``'s keys) was trained on."""
    if kind == "mlp":
        return state["encoder.layer.weight"].shape[1] // window
    return state[f"encoder.{kind}.weight_ih_l0"].shape[1]


def mlp(inputs: int, hidden: int, outputs: int) -> nn.Sequential:
    """Two ReLU layers of ``hidden`` units, then a linear output (the actor's and the critics' heads)."""
    return nn.Sequential(nn.Linear(inputs, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU(),
                         nn.Linear(hidden, outputs))


class ActorNet(nn.Module):
    """Observation window -> (loc, scale) of the pre-tanh Gaussian; ``lstm_hidden`` is the
    encoder's width whatever its kind (the name the policy files and configurations keep)."""

    def __init__(self, lstm_hidden: int = 64, mlp_hidden: int = 256, obs_size: int = OBS_SIZE,
                 action_size: int = ACTION_SIZE, encoder: str = "lstm", window: int = 8):
        super().__init__()
        self.obs_size = obs_size
        self.encoder = make_encoder(encoder, obs_size, lstm_hidden, window)
        self.head = mlp(lstm_hidden, mlp_hidden, 2 * action_size)
        # Scale through a softplus biased so that a zero input gives a standard deviation of 1,
        # bounded away from zero (TorchRL's usual choice for SAC).
        self.params = NormalParamExtractor(scale_mapping="biased_softplus_1", scale_lb=1e-4)

    def forward(self, window: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.params(self.head(self.encoder(window)))

    @torch.no_grad()
    def start_at_zero(self, std: float) -> None:
        """Make the mean action exactly zero for every input and the pre-tanh standard deviation
        about ``std``: a residual's network then starts by flying its base controller, exploring about it.
        The scale is set as softplus(x + b) with softplus(b) = 1, which leaves out the mapping's floor
        of 0.01 (0.306 for 0.3): kept so, as the residual runs measured were trained with it."""
        last = self.head[-1]
        half = last.out_features // 2
        last.weight.zero_()
        last.bias[:half] = 0.0
        last.bias[half:] = math.log(math.expm1(std)) - math.log(math.expm1(1.0))

    @torch.no_grad()
    def set_std(self, std: float) -> None:
        """Make the pre-tanh standard deviation exactly ``std`` for every input (above the scale
        mapping's floor); the mean is left as it is."""
        mapping = self.params.scale_mapping  # softplus(x + bias) + min_val
        if not std > mapping.min_val:
            raise ValueError(f"std must exceed the scale's floor {mapping.min_val}, got {std}")
        last = self.head[-1]
        half = last.out_features // 2
        last.weight[half:].zero_()
        last.bias[half:] = math.log(math.expm1(std - mapping.min_val)) - float(mapping.bias)
