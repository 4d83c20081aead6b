"""Goal relabelling: the stored state reproduces the environment's reward, and relabelled samples
get consistent goals and rewards."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from jsbsim_env.control.observation import OBS_OFFSET, OBS_SCALE
from jsbsim_env.sim.core import N_STATE
from jsbsim_env.task.attitude import (
    ACHIEVED_INDEX,
    GOAL_HIGH,
    GOAL_LOW,
    PENALTY_SATURATION,
    TaskConfig,
    reward_from_achieved,
    reward_terms,
)
from jsbsim_env.task.torchrl_env import make_env
from training.relabel import relabel_goals


@pytest.fixture(scope="module")
def rollout():
    env = make_env(num_envs=2, seed=5)
    torch.manual_seed(0)
    return env.rollout(60, break_when_any_done=False).reshape(-1)


def _goals(windows: torch.Tensor) -> np.ndarray:
    """Unscaled goals of the newest frame of each window."""
    return windows[:, -1, -3:].double().numpy() * OBS_SCALE[-3:] + OBS_OFFSET[-3:]


def test_vectorised_reward_matches_the_per_aircraft_one():
    rng = np.random.default_rng(1)
    for _ in range(200):
        state = rng.normal(0, 0.05, N_STATE)
        state[6] = rng.uniform(6, 14)
        goal = rng.uniform(GOAL_LOW, GOAL_HIGH)
        achieved = state[list(ACHIEVED_INDEX)]
        assert reward_from_achieved(achieved, goal) == pytest.approx(reward_terms(state, goal)[4], abs=1e-12)
        as_torch = reward_from_achieved(torch.tensor(achieved), torch.tensor(goal))
        assert float(as_torch) == pytest.approx(reward_terms(state, goal)[4], abs=1e-9)
        # A sideslip weight scales the sideslip penalty (and its cap) alone, in both.
        terms, weighted = reward_terms(state, goal), reward_terms(state, goal, 3.0)
        assert weighted[:3] == terms[:3] and weighted[3] == pytest.approx(3.0 * terms[3])
        assert reward_from_achieved(achieved, goal, 3.0) == pytest.approx(weighted[4], abs=1e-12)
        # So does a roll weight the roll penalty.
        rolled = reward_terms(state, goal, roll_weight=2.0)
        assert rolled[1:4] == terms[1:4] and rolled[0] == pytest.approx(2.0 * terms[0])
        assert reward_from_achieved(achieved, goal, roll_weight=2.0) == pytest.approx(rolled[4], abs=1e-12)
        # And a pitch weight the pitch penalty.
        pitched = reward_terms(state, goal, pitch_weight=2.0)
        assert pitched[0] == terms[0] and pitched[2:4] == terms[2:4] and pitched[1] == pytest.approx(2.0 * terms[1])
        assert reward_from_achieved(achieved, goal, pitch_weight=2.0) == pytest.approx(pitched[4], abs=1e-12)
        # A penalty tail changes nothing within the caps and agrees between the two as well.
        tailed = reward_terms(state, goal, 3.0, 0.2)
        assert reward_from_achieved(achieved, goal, 3.0, 0.2) == pytest.approx(tailed[4], abs=1e-12)
        assert float(reward_from_achieved(torch.tensor(achieved), torch.tensor(goal), 3.0, 0.2)) == \
            pytest.approx(tailed[4], abs=1e-9)
        assert tailed[4] <= weighted[4]


def test_a_penalty_tail_charges_errors_beyond_the_cap():
    state, goal = np.zeros(N_STATE), np.array([0.0, math.radians(-10.0), 10.0])
    state[6] = 10.0
    rewards = {}
    for pitch_deg in (0.0, 1.5, 2.0, 12.0):
        state[2] = goal[1] + math.radians(pitch_deg)
        rewards[pitch_deg] = (reward_terms(state, goal)[4], reward_terms(state, goal, penalty_tail=0.1)[4])
    assert rewards[2.0][0] == rewards[12.0][0] < rewards[0.0][0]  # Eq. 22: 12 deg costs no more than 2 deg
    assert rewards[12.0][1] < rewards[2.0][1] < rewards[2.0][0]  # the tail: it does
    assert rewards[1.5][1] == rewards[1.5][0]  # within the cap (1.8 deg of pitch) as Eq. 22
    assert rewards[2.0][0] - rewards[12.0][1] == pytest.approx(0.1 * (12.0 / 6.0 - 0.3))
    # A tail of 1 is the uncapped linear penalty.
    assert reward_terms(state, goal, penalty_tail=1.0)[1] == pytest.approx(12.0 / 6.0)
    with pytest.raises(ValueError, match="penalty_tail"):
        TaskConfig(penalty_tail=1.5)


def test_a_reshaped_reward_trains_on_its_reward_and_evaluates_on_eq_22():
    from training.trainer import evaluate_policy

    shaped = TaskConfig(sideslip_weight=3.0, penalty_tail=0.2, roll_weight=2.0, pitch_weight=1.5)
    env = make_env(num_envs=2, config=shaped, seed=5)
    torch.manual_seed(0)
    data = env.rollout(30, break_when_any_done=False).reshape(-1)
    achieved, goal = data["next", "achieved"].double().numpy(), _goals(data["observation"])
    np.testing.assert_allclose(data["next", "reward"].reshape(-1).double().numpy(),
                               reward_from_achieved(achieved, goal, 3.0, 0.2, 2.0, 1.5), atol=1e-5)
    relabelled = relabel_goals(data, 1.0, 2.0, torch.Generator().manual_seed(0), sideslip_weight=3.0,
                               penalty_tail=0.2, roll_weight=2.0, pitch_weight=1.5)
    new_goal = _goals(relabelled["observation"])
    np.testing.assert_allclose(relabelled["next", "reward"].reshape(-1).double().numpy(),
                               reward_from_achieved(achieved, new_goal, 3.0, 0.2, 2.0, 1.5), atol=1e-5)
    # The training-time evaluation scores with Eq. 22 whatever the run trains on.
    def policy(td):  # neutral surfaces and half throttle, the same in both evaluations
        return td.set("action", torch.zeros(td.shape[0], 4))

    weighted = evaluate_policy(policy, shaped, episodes=2, max_steps=20, seed=3)
    plain = evaluate_policy(policy, TaskConfig(), episodes=2, max_steps=20, seed=3)
    assert weighted["return_norm"] == plain["return_norm"]


def test_achieved_state_reproduces_the_environment_reward(rollout):
    # The reward of a step uses the goal the policy saw before it (the newest frame of the window).
    alive = ~rollout["next", "terminated"].reshape(-1)
    expected = reward_from_achieved(rollout["next", "achieved"].double().numpy(), _goals(rollout["observation"]))
    got = rollout["next", "reward"].reshape(-1).double().numpy()
    np.testing.assert_allclose(got[alive.numpy()], expected[alive.numpy()], atol=1e-5)


def test_no_relabelling_leaves_the_batch(rollout):
    assert relabel_goals(rollout, 0.0, 2.0) is rollout
    with pytest.raises(ValueError, match="fraction"):
        relabel_goals(rollout, 1.5, 2.0)


def test_relabelled_goals_and_rewards_are_consistent(rollout):
    before = rollout.clone()
    out = relabel_goals(rollout, 1.0, 2.0, generator=torch.Generator().manual_seed(0))
    assert (rollout == before).all(), "the input batch must not change"
    goals = _goals(out["observation"])
    # One goal held over both windows, every frame.
    for key in ("observation", ("next", "observation")):
        frames = out[key][..., -3:]
        assert torch.equal(frames, frames[:, -1:].expand_as(frames))
    assert torch.equal(out["observation"][:, -1, -3:], out["next", "observation"][:, -1, -3:])
    # The states themselves are untouched.
    assert torch.equal(out["observation"][..., :-3], rollout["observation"][..., :-3])
    # Within the spread of the state reached, inside the goal ranges.
    achieved = rollout["next", "achieved"].double().numpy()[:, :3]
    spread = 2.0 * np.array(PENALTY_SATURATION)
    assert np.all(np.abs(goals - achieved) <= spread + 1e-5)
    assert np.all(goals >= GOAL_LOW - 1e-6) and np.all(goals <= GOAL_HIGH + 1e-6)
    # The rewards are Eq. 22 for the new goals, and well spread over its sloped part.
    reward = out["next", "reward"].reshape(-1).double().numpy()
    np.testing.assert_allclose(reward, reward_from_achieved(rollout["next", "achieved"].double().numpy(), goals),
                               atol=1e-5)
    assert reward.std() > 0.05


def test_a_fraction_is_relabelled(rollout):
    big = torch.cat([rollout] * 20)
    out = relabel_goals(big, 0.3, 2.0, generator=torch.Generator().manual_seed(0))
    changed = (out["observation"][:, -1, -3:] != big["observation"][:, -1, -3:]).any(-1).float().mean()
    assert math.isclose(float(changed), 0.3, abs_tol=0.05)


def test_speed_free_transitions_keep_their_goals():
    env = make_env(num_envs=2, config=TaskConfig(external_throttle=1.0), seed=5)
    batch = env.rollout(10, break_when_any_done=False).reshape(-1)
    assert bool(batch["next", "speed_free"].all())
    out = relabel_goals(batch, 1.0, 2.0, generator=torch.Generator().manual_seed(0))
    assert torch.equal(out["observation"], batch["observation"])
    assert torch.equal(out["next", "reward"], batch["next", "reward"])
