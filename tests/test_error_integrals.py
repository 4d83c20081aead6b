"""Error integrals in the observation: their definition and exact relabelling (the runtime's are in
test_policy.py)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from jsbsim_env.sim.core import CoreConfig
from jsbsim_env.task.attitude import INTEGRAL_GAIN, OBS_SIZE, ErrorIntegrals, TaskConfig
from jsbsim_env.task.torchrl_env import make_env
from training.relabel import relabel_goals

DECAY = 0.99


def _scaled(roll: float, goal_roll: float) -> list[float]:
    """A 20-value scaled observation with only the roll and its goal set (scaled units)."""
    obs = [0.0] * OBS_SIZE
    obs[1], obs[-3] = roll, goal_roll
    return obs


def test_a_steady_error_reads_gain_times_the_error_and_a_goal_step_moves_it_at_once():
    integrals = ErrorIntegrals(DECAY)
    for _ in range(2000):
        out = integrals.extend(_scaled(0.30, 0.25))
    assert len(out) == OBS_SIZE + 5
    assert out[OBS_SIZE - 3] == pytest.approx(INTEGRAL_GAIN * 0.05, rel=1e-6)  # roll integral
    assert out[OBS_SIZE + 1] == pytest.approx(1.0, rel=1e-6)  # the weight has risen to 1
    assert out[-3:] == _scaled(0.30, 0.25)[-3:] and out[:OBS_SIZE - 3] == _scaled(0.30, 0.25)[:OBS_SIZE - 3]
    after_step = integrals.extend(_scaled(0.30, 0.35))  # goal steps by +0.1: the error turns to -0.05
    assert after_step[OBS_SIZE - 3] == pytest.approx(INTEGRAL_GAIN * -0.05, rel=1e-3)
    integrals.reset()
    first = integrals.extend(_scaled(0.30, 0.25))
    assert first[OBS_SIZE + 1] == pytest.approx(1.0 - DECAY)  # one sample in, after a reset
    assert first[OBS_SIZE - 3] == pytest.approx(INTEGRAL_GAIN * (1.0 - DECAY) * 0.05)


@pytest.fixture(scope="module")
def rollout():
    env = make_env(num_envs=2, config=TaskConfig(core=CoreConfig(turbulence=False), error_integral_decay=DECAY),
                   seed=6, critic_state=True)
    torch.manual_seed(0)
    return env.rollout(80, break_when_any_done=False).reshape(-1)


def test_the_environment_observes_them_before_the_goals(rollout):
    assert rollout["observation"].shape[-1] == OBS_SIZE + 5
    weight = rollout["next", "observation"][:, -1, OBS_SIZE + 1]
    assert float(weight.min()) > 0.0 and float(weight.max()) <= 1.0


def test_relabelling_moves_them_to_the_new_goal_exactly():
    """Windows of an episode flown under one goal, relabelled: each sample's integrals equal those
    the same measurements give when the goal drawn for it is held from the start."""
    from tensordict import TensorDict

    rng = np.random.default_rng(0)
    rolls = rng.normal(0.0, 0.2, size=30).tolist()
    integrals = ErrorIntegrals(DECAY)
    frames = [integrals.extend(_scaled(r, 0.1)) for r in rolls]
    windows = torch.tensor([frames[k - 8:k] for k in range(8, 31)], dtype=torch.float32)
    n = windows.shape[0] - 1
    batch = TensorDict({"observation": windows[:-1], "next": {
        "observation": windows[1:], "reward": torch.zeros(n, 1), "terminated": torch.zeros(n, 1, dtype=torch.bool),
        "achieved": torch.zeros(n, 4)}}, batch_size=[n])
    out = relabel_goals(batch, 1.0, 2.0, generator=torch.Generator().manual_seed(1), error_integrals=True)
    for i in range(n):
        goals = out["observation"][i, -1, -3:].tolist()  # roll, pitch, V_eas goals drawn for it (scaled)
        assert goals[0] != pytest.approx(0.1)
        held = ErrorIntegrals(DECAY)
        expected = [held.extend(_scaled(r, 0.0)[:-3] + goals) for r in rolls][i:i + 8]
        np.testing.assert_allclose(out["observation"][i].numpy(), np.array(expected), atol=1e-5)


def test_the_critics_state_ends_as_the_observation_and_is_relabelled_with_it(rollout):
    """The critics' state carries the same integrals and goals as the newest frame of the
    observation, before and after relabelling."""
    tail = slice(OBS_SIZE - 3, None)
    for td in (rollout, relabel_goals(rollout, 1.0, 2.0, generator=torch.Generator().manual_seed(2),
                                      error_integrals=True)):
        for key in ("observation", ("next", "observation")):
            state_key = "state" if key == "observation" else ("next", "state")
            torch.testing.assert_close(td[state_key][:, -8:], td[key][:, -1, tail])
