"""CAPS action-smoothness regularisation (Mysore et al., ICRA 2021), added to the SAC actor loss.

    L_T = || mu(s_t) - mu(s_t+1) ||_2          temporal: consecutive observations, similar actions
    L_S = || mu(s) - mu(s + eps) ||_2, eps ~ N(0, sigma_S^2)   spatial: nearby observations, similar actions
    L_actor += kappa_T * mean(L_T) + kappa_S * mean(L_S)

With per-action weights w (beyond the paper: ``CapsSettings.action_weights``), the differences
are taken as w * (mu - mu'), so that one surface may be smoothed less than another; all ones is
the paper's CAPS.

mu is the deterministic action (tanh of the Gaussian's mean). Observations are whole windows in
the network's scaled units, so sigma_S is in those units too.
"""

from __future__ import annotations

import math

import torch
from tensordict import TensorDictBase

from training.networks import ActorNet


def deterministic_action(actor_net: ActorNet, window: torch.Tensor) -> torch.Tensor:
    loc, _ = actor_net(window)
    return torch.tanh(loc)


def check_action_weights(weights, action_size: int) -> None:
    """Raise ``ValueError`` unless ``weights`` are ``action_size`` finite, non-negative numbers."""
    values = list(weights)
    if len(values) != action_size:
        raise ValueError(f"CAPS action weights need one value per action ({action_size}: aileron, elevator, rudder, "
                         f"throttle), got {len(values)}: {values}")
    if not all(isinstance(w, (int, float)) and math.isfinite(w) and w >= 0.0 for w in values):
        raise ValueError(f"CAPS action weights must be finite and non-negative, got {values}")


def caps_penalties(mu: torch.Tensor, mu_next: torch.Tensor, mu_near: torch.Tensor,
                   weights: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """Mean temporal and spatial penalties from the deterministic actions at s, s_t+1 and s + eps,
    each action's difference times its entry of ``weights`` where given."""
    d_next, d_near = mu - mu_next, mu - mu_near
    if weights is not None:
        weights = weights.to(d_next.device, d_next.dtype)  # a no-op where they already match
        d_next, d_near = d_next * weights, d_near * weights
    temporal = torch.linalg.vector_norm(d_next, dim=-1).mean()
    spatial = torch.linalg.vector_norm(d_near, dim=-1).mean()
    return temporal, spatial


def spatial_noise(obs: torch.Tensor, sigma_spatial: float, generator: torch.Generator | None = None) -> torch.Tensor:
    """Gaussian noise of std ``sigma_spatial`` shaped as the observation windows."""
    return torch.randn(obs.shape, generator=generator, device=obs.device, dtype=obs.dtype) * sigma_spatial


def caps_losses(actor_net: ActorNet, batch: TensorDictBase, sigma_spatial: float,
                generator: torch.Generator | None = None,
                weights: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """Mean temporal and spatial smoothness penalties over a replay batch."""
    obs = batch["observation"]
    next_obs = batch["next", "observation"]
    # One forward pass for the three inputs.
    noisy = obs + spatial_noise(obs, sigma_spatial, generator)
    actions = deterministic_action(actor_net, torch.cat([obs, next_obs, noisy], dim=0))
    return caps_penalties(*actions.chunk(3, dim=0), weights=weights)
