"""The controller shipped in the package: where it came from, and one disturbed episode."""

from __future__ import annotations

import json

from jsbsim_env.task import AttitudeTaskBatch, TaskConfig
from training.policy import PolicyRuntime, load_policy, onnx_source_digest, policy_digest, shipped_policy_path
from training.suite import EVAL_EPISODE_SEED, fly

RANDOM_ACTIONS_RETURN = 0.13  # normalised return of uniformly random actions on these episodes


def test_shipped_record_names_command_seed_and_commit():
    path = shipped_policy_path()
    record = json.loads(path.with_suffix(".json").read_text())
    _, meta = load_policy(path)
    assert record["seed"] == meta["seed"] and record["frames"] == meta["frames"]
    assert record["command"].startswith("python scripts/train_torchrl.py") and len(record["commit"]) == 40
    assert all(s["frames_at_start"] < meta["frames"] for s in record["sessions"])
    assert record["evaluation"]["episodes"]["count"] >= 50
    assert onnx_source_digest(path.with_suffix(".onnx")) == policy_digest(path)  # the export of this very file
    assert len(record["aircraft_model"]) == 64  # the fingerprint of the aircraft model it was trained on


def test_shipped_policy_flies_a_disturbed_episode_without_early_end():
    """A training-style episode (delay, noise, random interval, randomised coefficients,
    turbulence) that the evaluation suite does not use."""
    batch = AttitudeTaskBatch(1, TaskConfig())
    steps = 300
    _, end = fly(PolicyRuntime(), batch, seed=EVAL_EPISODE_SEED - 1, steps=steps)
    assert end["steps"] == steps and not end["terminated"], end
    assert end["return"] / steps > 2 * RANDOM_ACTIONS_RETURN
