"""Environment speed against raw JSBSim, in simulated seconds per wall-clock second.

In one process, interleaved in rounds (medians reported):

* raw: ``fdm.run()`` of the solar UAV at the environment's simulation rate;
* task: the attitude task (flight core with every disturbance on, reward, goals) without an RL library;
* torchrl single / batched: ``SolarUAVAttitudeEnv`` with 1 and ``--batch`` aircraft, every
  disturbance on, stepped through TorchRL's ``step`` and ``step_mdp``, resets included.

The actions hold each aircraft's trim command plus a little noise, so that episodes run their
full length like those of a trained policy. Ratios are env / raw.

    python scripts/bench_env.py --json
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np
import torch

from jsbsim_env.core import CoreConfig, FlightCore
from jsbsim_env.task import AttitudeTask, command_to_action
from jsbsim_env.torchrl_env import SolarUAVAttitudeEnv


def raw_rate(seconds: float) -> float:
    core = FlightCore(CoreConfig.ideal())
    core.reset(seed=0, altitude_m=10000.0, airspeed_eas_mps=10.0)
    run, n = core.sim.fdm.run, round(seconds / core.dt_s)
    t0 = time.perf_counter()
    for _ in range(n):
        run()
    return n * core.dt_s / (time.perf_counter() - t0)


def _hold_trim(setup, rng) -> np.ndarray:
    return np.clip(command_to_action(setup.trim_command) + 0.01 * rng.standard_normal(4), -1.0, 1.0)


def task_rate(seconds: float, seed: int) -> float:
    task, rng = AttitudeTask(), np.random.default_rng(seed)
    task.reset(seed)
    sim_s, t0 = 0.0, time.perf_counter()
    while sim_s < seconds:
        _, _, terminated, truncated, _ = task.step(_hold_trim(task.core.setup, rng))
        sim_s += task.core.setup.control_interval_s
        if terminated or truncated:
            task.reset(int(rng.integers(2**31)))
    return sim_s / (time.perf_counter() - t0)


def torchrl_rate(env: SolarUAVAttitudeEnv, seconds: float, seed: int) -> float:
    rng = np.random.default_rng(seed)
    td = env.reset()
    sim_s, t0 = 0.0, time.perf_counter()
    while sim_s < seconds:
        actions = np.stack([_hold_trim(c.setup, rng) for c in env.batch.cores]).astype(np.float32)
        td["action"] = torch.from_numpy(actions)
        sim_s += float(env.batch.interval_s.sum())
        td = env.step_and_maybe_reset(td)[1]
    return sim_s / (time.perf_counter() - t0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="simulated seconds per measurement and aircraft")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--batch", type=int, default=8)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    torch.set_num_threads(1)
    single, batched = SolarUAVAttitudeEnv(1, seed=1), SolarUAVAttitudeEnv(args.batch, seed=2)
    rates: dict[str, list[float]] = {"raw": [], "task": [], "torchrl_single": [], "torchrl_batched": []}
    for r in range(args.rounds):
        rates["raw"].append(raw_rate(args.seconds))
        rates["task"].append(task_rate(args.seconds, r))
        rates["torchrl_single"].append(torchrl_rate(single, args.seconds, r))
        rates["torchrl_batched"].append(torchrl_rate(batched, args.seconds * args.batch, r))
    result = {"sim_rate_hz": CoreConfig().sim_rate_hz, "batch": args.batch, "rounds": args.rounds}
    for name, values in rates.items():
        result[f"{name}_sim_s_per_wall_s"] = statistics.median(values)
        if name != "raw":
            result[f"{name}_over_raw"] = statistics.median(v / r for v, r in zip(values, rates["raw"]))
    print(json.dumps(result, indent=2) if args.json else "\n".join(f"{k:34s} {v}" for k, v in result.items()))


if __name__ == "__main__":
    main()
