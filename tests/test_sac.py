"""The package's SAC update against TorchRL's own ``SACLoss`` with the same networks and weights."""

from __future__ import annotations

import copy

import pytest
import torch
from tensordict import TensorDict

from jsbsim_env.control.observation import ACTION_SIZE, OBS_SIZE
from training.networks import CriticNet, make_actor, make_critic
from training.sac import RecurrentSAC, tanh_normal_sample
from training.sac_reference import SACLossReference

SETTINGS = {"gamma": 0.99, "tau": 0.005, "alpha": 0.2, "target_entropy": -4.0, "lr": 3e-4,
            "caps_kappa_temporal": 1.0, "caps_kappa_spatial": 2.0, "caps_sigma_spatial": 0.05, "caps_batch_size": 16}


def _batch(n: int = 64, window: int = 8, seed: int = 0) -> TensorDict:
    g = torch.Generator().manual_seed(seed)
    return TensorDict({
        "observation": torch.randn(n, window, OBS_SIZE, generator=g),
        "action": torch.rand(n, ACTION_SIZE, generator=g) * 2 - 1,
        "next": {"observation": torch.randn(n, window, OBS_SIZE, generator=g),
                 "reward": torch.rand(n, 1, generator=g),
                 "terminated": torch.rand(n, 1, generator=g) < 0.1},
    }, batch_size=[n])


@pytest.fixture(scope="module")
def pair():
    """The reference and ours, with the same actor, the same critic weights and the same targets."""
    from torchrl.data import Bounded

    torch.manual_seed(0)
    spec = Bounded(-1.0, 1.0, shape=(ACTION_SIZE,))
    actor = make_actor(16, 32, spec)
    reference = SACLossReference(actor, make_critic(16, 32), spec, auto_alpha=True, **SETTINGS)
    ours_actor = copy.deepcopy(actor)
    critics = []
    for i in range(2):
        critic = CriticNet(16, 32)
        online = reference.loss.qvalue_network_params.flatten_keys()
        critic.load_state_dict({k[len("module."):]: v[i].detach() for k, v in online.items()})
        critics.append(critic)
    ours = RecurrentSAC(ours_actor.module[0].module, critics, auto_alpha=True, **SETTINGS)
    target = reference.loss.target_qvalue_network_params.flatten_keys()
    for i, critic in enumerate(ours.target_critics):
        critic.load_state_dict({k[len("module."):]: v[i].detach() for k, v in target.items()})
    return reference, ours


def test_tanh_normal_log_density_is_the_change_of_variables():
    """log pi(a) against torch's own Normal and the tanh Jacobian, computed the direct way."""
    torch.manual_seed(1)
    # Where tanh saturates the direct form loses its digits: keep |u| within a few units here.
    loc, scale = 0.5 * torch.randn(1000, 4), 0.5 * torch.rand(1000, 4) + 0.1
    torch.manual_seed(2)
    action, log_prob = tanh_normal_sample(loc, scale)
    torch.manual_seed(2)
    u = loc + scale * torch.randn_like(loc)
    direct = torch.distributions.Normal(loc, scale).log_prob(u).sum(-1) - torch.log(1 - torch.tanh(u) ** 2).sum(-1)
    assert torch.allclose(action, torch.tanh(u))
    assert torch.allclose(log_prob, direct, atol=1e-4)


def test_losses_are_sacloss_s_in_expectation(pair):
    """Both sample actions, so the critic and actor losses agree as means over many draws (within
    their sampling error); CAPS' temporal term has no noise and agrees exactly."""
    reference, ours = pair
    batch = _batch()
    draws = 200
    ref_q, ref_pi, our_q, our_pi = [], [], [], []
    with torch.no_grad():
        for _ in range(draws):
            r = reference.losses(batch)
            o = ours.losses(batch)
            ref_q.append(float(r["loss_qvalue"]))
            ref_pi.append(float(r["loss_actor"]))
            our_q.append(float(o["loss_qvalue"]))
            our_pi.append(float(o["loss_actor"]))
    assert float(r["caps_temporal"]) == pytest.approx(float(o["caps_temporal"]), rel=1e-5)
    for ref_values, our_values in ((ref_q, our_q), (ref_pi, our_pi)):
        ref_t, our_t = torch.tensor(ref_values), torch.tensor(our_values)
        error = 4.0 * torch.sqrt((ref_t.var() + our_t.var()) / draws)  # 4 standard errors of the difference
        assert abs(float(ref_t.mean() - our_t.mean())) < float(error) + 1e-6


def test_one_update_moves_each_network_by_its_own_loss_only():
    """The actor loss reaches the actions through the critics' heads but leaves the critics' weights
    alone; the critic loss leaves the actor alone; the targets follow by tau."""
    from torchrl.data import Bounded

    torch.manual_seed(3)
    actor = make_actor(16, 32, Bounded(-1.0, 1.0, shape=(ACTION_SIZE,)))
    sac = RecurrentSAC(actor.module[0].module, [CriticNet(16, 32), CriticNet(16, 32)], auto_alpha=True, **SETTINGS)
    losses = sac.losses(_batch(seed=4))
    losses["loss_actor"].backward(retain_graph=True)
    assert all(p.grad is None or not p.grad.any() for p in sac.critics.parameters())
    assert any(p.grad is not None and p.grad.any() for p in sac.actor_net.parameters())
    sac.zero_grad(set_to_none=True)
    losses["loss_qvalue"].backward()
    assert all(p.grad is None or not p.grad.any() for p in sac.actor_net.parameters())
    before = [p.detach().clone() for p in sac.target_critics.parameters()]
    online_before = [p.detach().clone() for p in sac.critics.parameters()]
    sac.update(_batch(seed=5))
    for t0, o0, t1, o1 in zip(before, online_before, sac.target_critics.parameters(), sac.critics.parameters()):
        assert torch.allclose(t1, t0 + SETTINGS["tau"] * (o1.detach() - t0), atol=1e-7)


def test_more_threads_than_cores_is_warned_about():
    from training.runtime import available_cores, check_threads

    assert check_threads(1) is None
    with pytest.warns(RuntimeWarning, match="exceed the"):
        assert check_threads(available_cores(), processes=2) is not None


def test_allocator_thresholds_are_raised_on_glibc():
    import sys

    from training.runtime import tune_allocator

    assert tune_allocator() is sys.platform.startswith("linux")


def test_caps_action_weights_scale_each_actions_difference():
    """Zero weight on an action leaves its difference out; all ones is the paper's CAPS; bad
    weights are refused by name."""
    from training.caps import caps_penalties, check_action_weights

    mu = torch.zeros(5, ACTION_SIZE)
    moved = mu.clone()
    moved[:, 0] = 0.3  # only the aileron differs
    assert caps_penalties(mu, moved, moved) == caps_penalties(mu, moved, moved, torch.ones(ACTION_SIZE))
    temporal, spatial = caps_penalties(mu, moved, moved, torch.tensor([0.0, 1.0, 1.0, 1.0]))
    assert float(temporal) == 0.0 and float(spatial) == 0.0
    half, _ = caps_penalties(mu, moved, moved, torch.tensor([0.5, 1.0, 1.0, 1.0]))
    assert float(half) == pytest.approx(0.15)
    with pytest.raises(ValueError, match="one value per action"):
        check_action_weights([1.0, 1.0], ACTION_SIZE)
    with pytest.raises(ValueError, match="non-negative"):
        check_action_weights([1.0, -1.0, 1.0, float("nan")], ACTION_SIZE)
    with pytest.raises(ValueError, match="one value per action"):
        RecurrentSAC(make_actor(16, 32).module[0].module, [CriticNet(16, 32), CriticNet(16, 32)], auto_alpha=True,
                     caps_action_weights=[1.0, 1.0, 1.0], **SETTINGS)
