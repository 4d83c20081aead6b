"""Environment speed against raw JSBSim, in simulated seconds per wall-clock second.

In one process, interleaved in rounds (medians reported):

* raw: ``fdm.run()`` of the solar UAV at the environment's simulation rate;
* flight batchN: N flight cores (``FlightCore``: delay, gusts, state read-out, a fresh JSBSim
  instance per episode) flown in turn with no task or RL library: the floor under any
  environment built on them, which the ``over_flight`` ratios measure the environment against;
* task: the attitude task (flight core with every disturbance on, reward, goals) without an RL library;
* torchrl batchN: ``SolarUAVAttitudeEnv`` with 1 and ``--batch`` aircraft, every disturbance on,
  stepped through TorchRL's ``step_and_maybe_reset``, resets included;
* torchrl Kproc: K processes, each a batched environment, stepping at once (the two cores of
  this machine, as a multi-process collector would use them); measured after the rounds.

The actions hold wings level and pitch near trim by a little feedback (plus noise), computed for
all aircraft at once so that the benchmark's own work stays small, and episodes run their full
length like those of a trained policy. Ratios are env / raw (and env / flight).

    python scripts/bench_env.py --json
"""

from __future__ import annotations

import json
import statistics
import time

import numpy as np

from jsbsim_env.control.observation import ACTION_OFFSET, ACTION_SCALE, command_to_action
from jsbsim_env.sim.core import CoreConfig, FlightCore
from jsbsim_env.sim.trim_table import TrimTable
from jsbsim_env.task.attitude import AttitudeTask
from training.runtime import ScriptParser, non_negative_int, number_type, positive_float, rounds_int, run_command
from training.workers import process_pool

# torch and TorchRL (SolarUAVAttitudeEnv) load in the functions that use them, after the arguments
# are parsed.


def raw_rate(seconds: float) -> float:
    core = FlightCore(CoreConfig.ideal())
    core.reset(seed=0, altitude_m=10000.0, airspeed_eas_mps=10.0)
    run, n = core.sim.fdm.run, round(seconds / core.dt_s)
    t0 = time.perf_counter()
    for _ in range(n):
        run()
    return n * core.dt_s / (time.perf_counter() - t0)


def hold_attitude(cores, rng) -> np.ndarray:
    """Actions (N x 4) for wings level and trimmed pitch by proportional-derivative feedback on each
    aircraft's true state, so that episodes run their full length as under a trained policy (the
    spiral mode diverges otherwise)."""
    states = np.array([c.last_true_state for c in cores])
    command = np.array([c.setup.trim_command for c in cores])
    roll, pitch, p, q = np.degrees(states[:, 1:5]).T
    command[:, 0] += 1.5 * roll + 0.5 * p
    command[:, 1] += 2.0 * pitch + 0.5 * q
    return np.clip(command_to_action(command) + 0.01 * rng.standard_normal(command.shape), -1.0, 1.0)


def flight_rate(cores, seconds: float, seed: int) -> float:
    """The flight cores alone, flown in turn with new episodes as the environment starts them."""
    rng = np.random.default_rng(seed)
    for k, core in enumerate(cores):
        core.reset(seed + k)
        core.last_true_state = core.true_state()
    max_steps = cores[0].config.max_steps
    sim_s, t0 = 0.0, time.perf_counter()
    while sim_s < seconds:
        commands = (ACTION_OFFSET + ACTION_SCALE * hold_attitude(cores, rng)).tolist()
        for core, command in zip(cores, commands):
            core.fly(command)
            core.last_true_state = core.true_state()
            sim_s += core.setup.control_interval_s
            if core.step_index >= max_steps:
                core.reset(int(rng.integers(2**31)))
                core.last_true_state = core.true_state()
    return sim_s / (time.perf_counter() - t0)


def task_rate(seconds: float, seed: int) -> float:
    task, rng = AttitudeTask(), np.random.default_rng(seed)
    task.reset(seed)
    sim_s, t0 = 0.0, time.perf_counter()
    while sim_s < seconds:
        _, _, terminated, truncated, _ = task.step(hold_attitude([task.core], rng)[0])
        sim_s += task.core.setup.control_interval_s
        if terminated or truncated:
            task.reset(int(rng.integers(2**31)))
    return sim_s / (time.perf_counter() - t0)


def torchrl_rate(env, seconds: float, seed: int) -> float:
    """``env``: a ``SolarUAVAttitudeEnv``."""
    import torch

    rng = np.random.default_rng(seed)
    td = env.reset()
    sim_s, t0 = 0.0, time.perf_counter()
    while sim_s < seconds:
        td["action"] = torch.from_numpy(hold_attitude(env.batch.cores, rng).astype(np.float32))
        sim_s += float(env.batch.interval_s.sum())
        td = env.step_and_maybe_reset(td)[1]
    return sim_s / (time.perf_counter() - t0)


def _worker(args) -> tuple[float, float]:
    """One process of the multi-process measurement: (simulated seconds, wall seconds)."""
    import torch

    from jsbsim_env.task.torchrl_env import SolarUAVAttitudeEnv

    batch, seconds, seed = args
    torch.set_num_threads(1)
    TrimTable.shared().fill()
    env = SolarUAVAttitudeEnv(batch, seed=seed)
    rate = torchrl_rate(env, seconds * batch, seed)
    return seconds * batch, seconds * batch / rate


def processes_rate(processes: int, batch: int, seconds: float, seed: int) -> float:
    """Simulated seconds per wall second of ``processes`` processes, each a batched environment
    (what a multi-process collector gets on this machine)."""
    with process_pool(processes) as pool:
        t0 = time.perf_counter()
        results = list(pool.map(_worker, [(batch, seconds, seed + k) for k in range(processes)]))
        wall = time.perf_counter() - t0
    # Start-up (imports, trim table) is excluded: each worker reports its own stepping time.
    return sum(sim for sim, _ in results) / max(w for _, w in results) if wall > 0 else 0.0


def main(argv: list[str] | None = None) -> None:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=positive_float, default=100.0, help="simulated seconds per measurement and aircraft")
    parser.add_argument("--rounds", type=rounds_int, default=3, help="repeats of each measurement; the median is reported")
    parser.add_argument("--batch", type=number_type(int, 1, 4096), nargs="+", default=[8, 32], help="aircraft per batched environment")
    parser.add_argument("--processes", type=non_negative_int, default=2,
                        help="processes for the multi-process figure (0 or 1: skip it)")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args(argv)
    import torch

    from jsbsim_env.task.torchrl_env import SolarUAVAttitudeEnv

    torch.set_num_threads(1)
    TrimTable.shared().fill()  # trims are cached per process; keep their first computation out of the timings
    envs = {1: SolarUAVAttitudeEnv(1, seed=1), **{n: SolarUAVAttitudeEnv(n, seed=n) for n in args.batch}}
    flights = {n: [FlightCore(CoreConfig()) for _ in range(n)] for n in envs}
    rates: dict[str, list[float]] = {"raw": [], "task_single": []}
    for n in envs:
        rates[f"flight_batch{n}"] = []
        rates[f"torchrl_batch{n}"] = []
    for r in range(args.rounds):
        rates["raw"].append(raw_rate(args.seconds))
        rates["task_single"].append(task_rate(args.seconds, r))
        for n, env in envs.items():
            rates[f"flight_batch{n}"].append(flight_rate(flights[n], args.seconds * n, 1000 * r))
            rates[f"torchrl_batch{n}"].append(torchrl_rate(env, args.seconds * n, r))
    result = {"sim_rate_hz": CoreConfig().sim_rate_hz, "rounds": args.rounds}
    for name, values in rates.items():
        result[f"{name}_sim_s_per_wall_s"] = statistics.median(values)
        if name != "raw":
            result[f"{name}_over_raw"] = statistics.median(v / r for v, r in zip(values, rates["raw"]))
    for n in envs:  # what the task and TorchRL layers cost on top of the flight cores they drive
        result[f"torchrl_batch{n}_over_flight"] = statistics.median(
            v / f for v, f in zip(rates[f"torchrl_batch{n}"], rates[f"flight_batch{n}"]))
    if args.processes > 1:
        n = args.batch[0]
        rate = processes_rate(args.processes, n, args.seconds, 100)
        key = f"torchrl_{args.processes}proc_batch{n}"
        result[f"{key}_sim_s_per_wall_s"] = rate
        result[f"{key}_over_raw"] = rate / result["raw_sim_s_per_wall_s"]
    print(json.dumps(result, indent=2) if args.json else "\n".join(f"{k:40s} {v}" for k, v in result.items()))


if __name__ == "__main__":
    run_command(main, __file__)
