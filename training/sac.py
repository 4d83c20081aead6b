"""Soft Actor-Critic with CAPS for the recurrent networks, one forward and one backward pass per update.

The losses are TorchRL's ``SACLoss`` (version 2: twin critics, no value network, tuned or fixed
temperature) plus CAPS (``training.caps``), written out for these networks so that no work is
done twice (``scripts/bench_train.py`` times it against ``SACLoss`` with the same networks):

* the actor's LSTM runs once, on the batch's observations, on the next observations of the CAPS
  subset and on their noisy copies; the target actions of the remaining next observations come
  from one pass without gradients;
* each critic's LSTM runs once on the observations: its features feed the critic loss and,
  detached, the actor loss, whose gradient reaches the actions only (the critic's head enters it
  with detached weights, so the actor loss leaves the critics untouched);
* one backward pass and one Adam step (fused where torch offers it) over all parameters, and the
  targets follow with one ``torch._foreach_lerp_``.

Losses, as ``SACLoss``: critic ``mean_b sum_i (Q_i(s, a) - y)^2`` with
``y = r + gamma (1 - terminated) (min_i Q'_i(s', a') - alpha log pi(a'|s'))``; actor
``mean(alpha log pi(a~|s) - min_i Q_i(s, a~))``; temperature ``-log_alpha (log pi + H_target)``.
"""

from __future__ import annotations

import copy
import math

import torch
import torch.nn.functional as F
from tensordict import TensorDictBase
from torch import nn

from jsbsim_env.control.observation import ACTION_SIZE
from training.caps import caps_penalties, check_action_weights, spatial_noise
from training.networks import ActorNet, CriticNet

LOG_2 = math.log(2.0)


def tanh_normal_sample(loc: torch.Tensor, scale: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """A reparameterised sample of tanh(N(loc, scale)) and its log-density (summed over the action).

    log pi(a) = log N(u) - sum log(1 - tanh(u)^2), with log(1 - tanh(u)^2) = 2 (log 2 - u - softplus(-2u)),
    the form that stays finite where tanh saturates.
    """
    eps = torch.randn_like(loc)
    u = loc + scale * eps
    log_normal = -0.5 * eps.square() - scale.log() - 0.5 * math.log(2.0 * math.pi)
    log_det = 2.0 * (LOG_2 - u - F.softplus(-2.0 * u))
    return torch.tanh(u), (log_normal - log_det).sum(-1)


def _head_without_weight_gradients(head: nn.Sequential, x: torch.Tensor) -> torch.Tensor:
    """``head(x)`` with its weights detached: gradients reach ``x`` but not the head."""
    for layer in head:
        x = F.linear(x, layer.weight.detach(), layer.bias.detach()) if isinstance(layer, nn.Linear) else layer(x)
    return x


class RecurrentSAC(nn.Module):
    """The actor (shared with the collector's policy), twin critics, their targets and the temperature.

    Args:
        actor_net: the actor's network, the same module the collector's policy runs.
        critics: the two online critics; their targets start as copies.
        alpha: the initial (or, with ``auto_alpha`` off, fixed) temperature.
        auto_alpha: tune the temperature towards ``target_entropy``.
        caps_action_weights: each action's weight in the CAPS differences (``training.caps``);
            None weighs all alike, as the paper.
        imitation_weight: where a batch has ``teacher_action`` and ``imitation_mask`` (a distilling
            run's), the actor loss adds this times the batch's mean |Q| times the mean squared
            difference of its actions from the teacher's on the masked rows (TD3+BC's term).
    """

    def __init__(self, actor_net: ActorNet, critics: list[CriticNet], gamma: float, tau: float,
                 alpha: float, auto_alpha: bool, target_entropy: float, lr: float, caps_kappa_temporal: float,
                 caps_kappa_spatial: float, caps_sigma_spatial: float, caps_batch_size: int,
                 caps_action_weights: list[float] | None = None, imitation_weight: float = 0.0):
        super().__init__()
        self.actor_net = actor_net
        self.critics = nn.ModuleList(critics)
        # An asymmetric critic reads the batch's ``privileged`` entries (``training.networks.CriticNet``).
        self.privileged = critics[0].privileged_size > 0
        self.target_critics = copy.deepcopy(self.critics).requires_grad_(False)
        self.log_alpha = nn.Parameter(torch.tensor(math.log(alpha)), requires_grad=auto_alpha)
        self.gamma, self.tau, self.target_entropy = gamma, tau, target_entropy
        self.auto_alpha = auto_alpha
        # A distilling run's pull towards its teacher in the actor loss (``imitation_mask`` rows).
        self.imitation_weight = imitation_weight
        self.caps = (caps_kappa_temporal, caps_kappa_spatial, caps_sigma_spatial, caps_batch_size)
        if caps_action_weights is not None:
            check_action_weights(caps_action_weights, ACTION_SIZE)
        if caps_action_weights is not None and any(w != 1.0 for w in caps_action_weights):
            # A buffer, so that it follows the module to its device; all ones is the paper's CAPS.
            self.register_buffer("caps_weights", torch.tensor(caps_action_weights, dtype=torch.float32))
        else:
            self.caps_weights = None
        # One Adam group for the actor, one for the critics, and the temperature's where it is tuned.
        params = [{"params": list(actor_net.parameters())}, {"params": list(self.critics.parameters())}]
        if auto_alpha:
            params.append({"params": [self.log_alpha]})
        # Adam's fused kernel steps every parameter in one call (CPU and CUDA in current torch).
        try:
            self.optimizer = torch.optim.Adam(params, lr=lr, fused=True)
        except (RuntimeError, TypeError):
            self.optimizer = torch.optim.Adam(params, lr=lr, foreach=True)
        self._online = list(self.critics.parameters())
        self._target = list(self.target_critics.parameters())

    def losses(self, batch: TensorDictBase) -> dict[str, torch.Tensor]:
        """Every loss term of one update, and what is logged (``loss_*``, ``caps_*``, ``alpha``, ``entropy``)."""
        kappa_t, kappa_s, sigma_s, caps_n = self.caps
        obs, next_obs = batch["observation"], batch["next", "observation"]
        n = obs.shape[0]
        m = min(caps_n, n)
        alpha = self.log_alpha.exp()

        # The actor, once with gradients: observations, the CAPS subset's next and noisy observations.
        windows = [obs, next_obs[:m], obs[:m] + spatial_noise(obs[:m], sigma_s)]
        loc, scale = self.actor_net(torch.cat(windows, dim=0))
        loc_obs, scale_obs = loc[:n], scale[:n]
        action, log_prob = tanh_normal_sample(loc_obs, scale_obs)
        loc_next_caps = loc[n:n + m]
        caps_temporal, caps_spatial = caps_penalties(torch.tanh(loc[:m]), torch.tanh(loc_next_caps),
                                                     torch.tanh(loc[n + m:n + 2 * m]), self.caps_weights)

        with torch.no_grad():
            if m < n:
                rest_loc, rest_scale = self.actor_net(next_obs[m:])
                next_loc = torch.cat([loc[n:n + m].detach(), rest_loc])
                next_scale = torch.cat([scale[n:n + m].detach(), rest_scale])
            else:
                next_loc, next_scale = loc[n:n + m].detach(), scale[n:n + m].detach()
            next_action, next_log_prob = tanh_normal_sample(next_loc, next_scale)
            next_input = batch["next", "observation"]
            next_privileged = batch["next", "privileged"] if self.privileged else None
            next_q = torch.min(torch.stack([c(next_input, next_action, next_privileged)
                                            for c in self.target_critics]), dim=0).values
            not_done = 1.0 - batch["next", "terminated"].to(obs.dtype)
            target = batch["next", "reward"] + self.gamma * not_done * (next_q - alpha.detach() * next_log_prob[:, None])

        privileged = batch["privileged"] if self.privileged else None
        features = [c.features(batch["observation"], privileged) for c in self.critics]
        q = [c.head(torch.cat([f, batch["action"]], dim=-1)) for c, f in zip(self.critics, features)]
        loss_qvalue = sum((qi - target).square() for qi in q).mean()
        q_pi = torch.min(torch.stack([_head_without_weight_gradients(c.head, torch.cat([f.detach(), action], dim=-1))
                                      for c, f in zip(self.critics, features)]), dim=0).values
        loss_actor = (alpha.detach() * log_prob - q_pi.squeeze(-1)).mean()
        anchored = batch.get("imitation_mask", None)
        extra = {}
        if anchored is not None and self.imitation_weight > 0.0:
            # TD3+BC's term: the actions flown (tanh of the mean) towards the teacher's, scaled by
            # the batch's mean |Q| so that its weight does not depend on the size of the returns.
            imitation = (torch.tanh(loc_obs) - batch["teacher_action"]).square().mean(-1)
            loss_imitation = (imitation * anchored).sum() / anchored.sum().clamp(min=1.0)
            loss_actor = loss_actor + self.imitation_weight * q_pi.detach().abs().mean() * loss_imitation
            extra["loss_imitation"] = loss_imitation.detach()
        loss_alpha = -(self.log_alpha * (log_prob.detach() + self.target_entropy)).mean()
        return {**extra, "loss_qvalue": loss_qvalue, "loss_actor": loss_actor, "loss_alpha": loss_alpha,
                "caps_temporal": caps_temporal, "caps_spatial": caps_spatial,
                "total": loss_qvalue + loss_actor + kappa_t * caps_temporal + kappa_s * caps_spatial
                + (loss_alpha if self.auto_alpha else 0.0),
                "alpha": alpha.detach(), "entropy": -log_prob.detach().mean()}

    def update(self, batch: TensorDictBase, actor: bool = True) -> dict[str, float]:
        """One gradient step of every network and the temperature, then the soft target update;
        with ``actor`` false, of the critics alone (the actor and the temperature stay)."""
        losses = self.losses(batch)
        self.optimizer.zero_grad(set_to_none=True)
        (losses["total"] if actor else losses["loss_qvalue"]).backward()
        self.optimizer.step()
        with torch.no_grad():
            torch._foreach_lerp_(self._target, self._online, self.tau)
        return {k: float(v.detach()) for k, v in losses.items() if k not in ("total", "loss_alpha")}

    def imitation_update(self, batch: TensorDictBase) -> dict[str, float]:
        """One gradient step of the actor's mean towards the batch's ``teacher_action``: the mean
        squared difference of the actions flown (tanh of the mean), in [-1, 1] units."""
        loc, _ = self.actor_net(batch["observation"])
        loss = (torch.tanh(loc) - batch["teacher_action"]).square().mean()
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()
        return {"loss_imitation": float(loss.detach())}
