"""Deterministic evaluation of a policy on a fixed, seeded set of training-style episodes."""

from __future__ import annotations

import torch
from torchrl.envs.utils import ExplorationType, set_exploration_type, step_mdp

from jsbsim_env.task import TaskConfig
from jsbsim_env.torchrl_env import make_env

EVAL_SEED = 20240428  # the evaluation episodes are the same for every run and every evaluation


@torch.no_grad()
def evaluate_policy(policy, task_config: TaskConfig, episodes: int = 8, max_steps: int = 500, window: int = 8,
                    seed: int = EVAL_SEED) -> dict:
    """Fly ``episodes`` episodes side by side with the deterministic policy, each once.

    Returns the mean normalised return (episode reward / max_steps, SPEC Fig. 8), the mean episode
    length and the number of episodes that ended early (terminated, not truncated).
    """
    env = make_env(episodes, task_config, seed=seed, window=window)
    td = env.reset()
    active = torch.ones(episodes, dtype=torch.bool)
    total = torch.zeros(episodes)
    length = torch.zeros(episodes)
    early = torch.zeros(episodes, dtype=torch.bool)
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        for _ in range(max_steps):
            td = env.step(policy(td))
            reward = td["next", "reward"].reshape(episodes)
            total += reward * active
            length += active.float()
            early |= td["next", "terminated"].reshape(episodes) & active
            active &= ~td["next", "done"].reshape(episodes)
            if not active.any():
                break
            td = step_mdp(td)
    env.close()
    return {"return_norm": float(total.mean()) / max_steps, "length": float(length.mean()),
            "early_ends": int(early.sum()), "episodes": episodes}
