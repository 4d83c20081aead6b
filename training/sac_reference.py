"""TorchRL's own ``SACLoss`` update with the same networks and CAPS: the reference that
``training.sac.RecurrentSAC`` is timed against (``scripts/bench_train.py``) and checked against
(``tests/test_sac.py``).
"""

from __future__ import annotations

import torch
from tensordict import TensorDictBase
from torchrl.objectives import SACLoss, SoftUpdate

from training.caps import caps_losses


class SACLossReference:
    """One SAC update with ``SACLoss`` (twin critics, no vmap: ``nn.LSTM`` cannot run under it),
    CAPS on the first ``caps_batch_size`` samples, an Adam per network and ``SoftUpdate``."""

    def __init__(self, actor, critic, action_spec, gamma: float, tau: float, alpha: float, auto_alpha: bool,
                 target_entropy: float, lr: float, caps_kappa_temporal: float, caps_kappa_spatial: float,
                 caps_sigma_spatial: float, caps_batch_size: int, caps_action_weights: list[float] | None = None):
        self.actor = actor
        self.caps_weights = None if caps_action_weights is None else torch.tensor(caps_action_weights)
        self.loss = SACLoss(actor, critic, num_qvalue_nets=2, loss_function="l2", alpha_init=alpha,
                            fixed_alpha=not auto_alpha, action_spec=action_spec, target_entropy=target_entropy,
                            deactivate_vmap=True)
        self.loss.make_value_estimator(gamma=gamma)
        self.target_update = SoftUpdate(self.loss, tau=tau)
        self.optimisers = [torch.optim.Adam(self.loss.actor_network_params.flatten_keys().values(), lr=lr),
                           torch.optim.Adam(self.loss.qvalue_network_params.flatten_keys().values(), lr=lr)]
        if auto_alpha:
            self.optimisers.append(torch.optim.Adam([self.loss.log_alpha], lr=lr))
        self.caps = (caps_kappa_temporal, caps_kappa_spatial, caps_sigma_spatial, caps_batch_size)

    def losses(self, batch: TensorDictBase) -> dict[str, torch.Tensor]:
        """``SACLoss``'s terms and CAPS, with the total one backward pass takes."""
        kappa_t, kappa_s, sigma_s, caps_n = self.caps
        losses = self.loss(batch)
        temporal, spatial = caps_losses(self.actor.module[0].module, batch[: min(caps_n, batch.shape[0])], sigma_s,
                                        weights=self.caps_weights)
        total = losses["loss_qvalue"] + losses["loss_actor"] + kappa_t * temporal + kappa_s * spatial
        if len(self.optimisers) == 3:
            total = total + losses["loss_alpha"]
        return {"loss_qvalue": losses["loss_qvalue"], "loss_actor": losses["loss_actor"],
                "caps_temporal": temporal, "caps_spatial": spatial, "total": total}

    def update(self, batch: TensorDictBase) -> None:
        losses = self.losses(batch)
        for opt in self.optimisers:
            opt.zero_grad(set_to_none=True)
        losses["total"].backward()
        for opt in self.optimisers:
            opt.step()
        self.target_update.step()
