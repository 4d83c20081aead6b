"""Recurrent actor and critics of the paper's Section 3.3.

Both read the last ``window`` observations, oldest first, through one LSTM layer (64 units; or
the GRU or windowed MLP of ``jsbsim_env.control.network.ENCODERS``, ``network.encoder``) and
continue from its last output: the actor with two 256-unit ReLU layers to the mean and standard
deviation of a tanh-squashed Gaussian, each critic by concatenating the action and two 256-unit
ReLU layers to Q. The actor and the two critics each have their own LSTM. An asymmetric critic
also reads the present step's privileged information (the true state, the turbulence, the
episode's coefficients...) beside its LSTM's output; the actor never does.
The actor's network is the one that flies (``jsbsim_env.control.network``).
"""

from __future__ import annotations

import torch
from tensordict.nn import TensorDictModule
from torch import nn
from torchrl.modules import ProbabilisticActor, TanhNormal

from jsbsim_env.control.network import ActorNet, make_encoder, mlp
from jsbsim_env.control.observation import ACTION_SIZE, OBS_SIZE


class CriticNet(nn.Module):
    """(observation window, action) -> Q; with ``privileged_size`` > 0 (an asymmetric critic) the
    present step's privileged information (``jsbsim_env.task.attitude.PRIVILEGED_NAMES``) joins the
    LSTM's output before the head."""

    def __init__(self, lstm_hidden: int = 64, mlp_hidden: int = 256, obs_size: int = OBS_SIZE,
                 action_size: int = ACTION_SIZE, privileged_size: int = 0, encoder: str = "lstm", window: int = 8):
        super().__init__()
        self.privileged_size = privileged_size
        self.encoder = make_encoder(encoder, obs_size, lstm_hidden, window)
        self.head = mlp(lstm_hidden + privileged_size + action_size, mlp_hidden, 1)

    def features(self, window: torch.Tensor, privileged: torch.Tensor | None = None) -> torch.Tensor:
        """What the head reads besides the action."""
        encoded = self.encoder(window)
        return encoded if privileged is None else torch.cat([encoded, privileged], dim=-1)

    def forward(self, window: torch.Tensor, action: torch.Tensor, privileged: torch.Tensor | None = None) -> torch.Tensor:
        return self.head(torch.cat([self.features(window, privileged), action], dim=-1))


def make_actor(lstm_hidden: int = 64, mlp_hidden: int = 256, action_spec=None, encoder: str = "lstm",
               window: int = 8, obs_size: int = OBS_SIZE) -> ProbabilisticActor:
    """The SAC actor: ``observation`` -> ``action`` (in [-1, 1]) with ``loc``/``scale``."""
    module = TensorDictModule(ActorNet(lstm_hidden, mlp_hidden, obs_size=obs_size, encoder=encoder, window=window),
                              in_keys=["observation"], out_keys=["loc", "scale"])
    return ProbabilisticActor(
        module, in_keys=["loc", "scale"], spec=action_spec, distribution_class=TanhNormal,
        distribution_kwargs={"low": -1.0, "high": 1.0}, return_log_prob=False,
    )


def make_critic(lstm_hidden: int = 64, mlp_hidden: int = 256, privileged_size: int = 0, encoder: str = "lstm",
                window: int = 8, obs_size: int = OBS_SIZE) -> TensorDictModule:
    """One Q network: (``observation``, ``action``[, ``privileged``]) -> ``state_action_value``."""
    keys = ["observation", "action"] + (["privileged"] if privileged_size else [])
    net = CriticNet(lstm_hidden, mlp_hidden, obs_size=obs_size, privileged_size=privileged_size, encoder=encoder,
                    window=window)
    return TensorDictModule(net, in_keys=keys, out_keys=["state_action_value"])
