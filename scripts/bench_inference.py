"""Per-step latency of the controller runtime on one CPU thread (median and p99).

One step is what the aircraft's computer does each control interval: scale the measurement, push it
into the 8-step window, run the network, map the action to actuator commands.

    python scripts/bench_inference.py --json [--policy PATH]
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from training.runtime import ScriptParser, number_type, run_command

# torch, onnxruntime and the policy runtime load in main(), after the arguments are parsed.


def timed_us(call, steps: int) -> np.ndarray:
    """Wall time of ``call(k)`` for k = 0 .. steps-1, in microseconds."""
    out = np.empty(steps)
    for k in range(steps):
        t0 = time.perf_counter()
        call(k)
        out[k] = time.perf_counter() - t0
    return out * 1e6


CONTROL_INTERVAL_S = 0.04  # the routes' 25 Hz; read by a policy whose control stack has trims


def latencies_us(runtime, steps: int, rng: np.random.Generator) -> np.ndarray:
    measurements = rng.normal(size=(steps, 13)) * 0.01 + np.array([10000, 0, 0, 0, 0, 0, 10, 0, 0, 0, 0, 0, 0.3])
    goal = np.array([0.0, 0.0, 10.0])
    runtime.reset()
    return timed_us(lambda k: runtime.act(measurements[k], goal, CONTROL_INTERVAL_S), steps)


def main(argv: list[str] | None = None) -> None:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--policy", type=Path, help="policy file (.pt); the shipped controller when omitted")
    parser.add_argument("--steps", type=number_type(int, 5), default=5000,
                        help="control steps timed (torch: a fifth of them)")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args(argv)
    import torch

    from jsbsim_env.control.policy import PolicyFileError, PolicyRuntime

    torch.set_num_threads(1)
    rng = np.random.default_rng(0)
    result = {"steps": args.steps}
    for backend in ("onnx", "torch"):
        try:
            runtime = PolicyRuntime(args.policy, backend=backend)
        except PolicyFileError as err:
            raise SystemExit(f"bench_inference: {err}") from None
        latencies_us(runtime, 200, rng)  # warm-up
        lat = latencies_us(runtime, args.steps if backend == "onnx" else args.steps // 5, rng)
        result[f"{backend}_median_us"] = float(np.median(lat))
        result[f"{backend}_p99_us"] = float(np.percentile(lat, 99))
        if backend == "onnx":
            # Reference in the same process, against the machine's noise: the bare network call.
            window = np.zeros((runtime.window, runtime.observation_size), dtype=np.float32)
            net = timed_us(lambda _, act=runtime.action, w=window: act(w), args.steps)
            result["onnx_network_median_us"] = float(np.median(net))
            result["onnx_step_over_network"] = result["onnx_median_us"] / result["onnx_network_median_us"]
    print(json.dumps(result, indent=2) if args.json else "\n".join(f"{k:20s} {v:.1f}" for k, v in result.items()))


if __name__ == "__main__":
    run_command(main, __file__)
