"""Goal relabelling of replayed transitions (in the spirit of hindsight experience replay).

The Eq. 22 reward saturates once an error passes 1.5 deg of roll, 1.8 deg of pitch or 1.5 m/s
of airspeed, and goals are drawn across +-5 deg, +-10 deg and 8-12 m/s, so early in training
almost every transition sits on the flat part of the reward for roll and pitch: the critics see
no difference between near and far, and the actor learns to hold airspeed while ignoring the
attitude goals. The aircraft's motion does not depend on the goal and the reward is a known
function of the true state reached and the goal, so any transition is also a valid transition
for any other goal held over it. Relabelling a share of each batch with goals drawn close to the
state actually reached puts those samples where the reward has a slope.

For a relabelled sample the goal columns of every frame of both observation windows are
replaced by the new goal (held over the window), and the reward is recomputed from the
transition's ``achieved`` state (``task.reward_from_achieved``). Surface trims (which the policy
does not observe) are part of the aircraft's state, though under the new goal they would have been
integrated differently (a small bias, slow as the trims are). Terminated transitions keep their
goal: their reward is the episode's last and their state may not be finite. So do speed-free
transitions (``("next", "speed_free")``, where a speed hold flew the throttle): their
EAS goal is the measured EAS and their reward has no airspeed term.
"""

from __future__ import annotations

import torch
from tensordict import TensorDictBase

from jsbsim_env.control.observation import GOAL_COLUMNS as _GOAL_COLUMNS
from jsbsim_env.control.observation import OBS_OFFSET, OBS_SCALE
from jsbsim_env.task.attitude import GOAL_HIGH, GOAL_LOW, PENALTY_SATURATION, reward_from_achieved

# A relabelled goal lies within this many times each channel's saturation error of the state reached.
RELABEL_SPREAD = 2.0
_GOAL_OFFSET = torch.tensor(OBS_OFFSET[_GOAL_COLUMNS], dtype=torch.float32)
_GOAL_SCALE = torch.tensor(OBS_SCALE[_GOAL_COLUMNS], dtype=torch.float32)
_GOAL_LOW = torch.tensor(GOAL_LOW, dtype=torch.float32)
_GOAL_HIGH = torch.tensor(GOAL_HIGH, dtype=torch.float32)
_SATURATION = torch.tensor(PENALTY_SATURATION, dtype=torch.float32)
_GOAL_KEYS = ("observation", ("next", "observation"))


def relabel_goals(batch: TensorDictBase, fraction: float, spread: float = RELABEL_SPREAD,
                  generator: torch.Generator | None = None, sideslip_weight: float = 1.0,
                  penalty_tail: float = 0.0, roll_weight: float = 1.0, pitch_weight: float = 1.0,
                  goal_range: tuple | None = None) -> TensorDictBase:
    """A copy of ``batch`` with goals and rewards of a random ``fraction`` of its samples relabelled.

    Args:
        batch: replay samples with ``observation`` and ``("next", "observation")`` windows
            (B, window, observation size), ``("next", "achieved")`` (B, 4), ``("next", "reward")``
            (B, 1) and ``("next", "terminated")`` (B, 1).
        fraction: share of the samples to relabel, in [0, 1].
        spread: new goal = achieved state + an offset drawn uniformly within +- ``spread`` times
            each channel's saturation error, clipped to the goal ranges.
        generator: random stream for the choice and the offsets.
        sideslip_weight, penalty_tail, roll_weight, pitch_weight: the training reward's (``task.TaskConfig``).
        goal_range: the lowest and highest goals (roll, pitch rad; EAS m/s) of the task's aircraft
            (``task.attitude.goal_range``); the paper's aircraft's (``GOAL_LOW``, ``GOAL_HIGH``) when None.
    """
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"relabel fraction must lie in [0, 1], got {fraction}")
    if fraction == 0.0:
        return batch
    n = batch.shape[0]
    device = batch["observation"].device
    chosen = torch.rand(n, generator=generator) < fraction
    chosen &= ~batch["next", "terminated"].reshape(n).cpu()
    if ("next", "speed_free") in batch.keys(include_nested=True):
        chosen &= ~batch["next", "speed_free"].reshape(n).cpu()
    index = chosen.nonzero().squeeze(-1).to(device)
    if index.numel() == 0:
        return batch
    achieved = batch["next", "achieved"][index].float()
    offset = (torch.rand(index.numel(), 3, generator=generator) * 2.0 - 1.0) * (spread * _SATURATION)
    low, high = (_GOAL_LOW, _GOAL_HIGH) if goal_range is None else (
        torch.as_tensor(bound, dtype=torch.float32) for bound in goal_range)
    goal = torch.minimum(torch.maximum(achieved[:, :3] + offset.to(device), low.to(device)), high.to(device))
    scaled = ((goal - _GOAL_OFFSET.to(device)) / _GOAL_SCALE.to(device)).unsqueeze(-2)
    out = batch.clone()
    for key in _GOAL_KEYS:
        values = out[key]
        values[index, ..., _GOAL_COLUMNS] = scaled.to(values.dtype)
    reward = reward_from_achieved(achieved, goal, sideslip_weight, penalty_tail, roll_weight, pitch_weight)
    out["next", "reward"][index] = reward.unsqueeze(-1).to(out["next", "reward"].dtype)
    return out
