"""Fly the shipped controller (or ``--policy PATH``, or the PID baseline) on the fixed evaluation
suite and print the metrics.

    python scripts/evaluate.py --json                   # metrics as JSON
    python scripts/evaluate.py --plots results/eval     # and the Fig. 9 time histories
    python scripts/evaluate.py --controller pid --json  # the gain-scheduled PID on the same suite
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import torch

from jsbsim_env.control.pid import PIDAttitudeController
from jsbsim_env.task.metrics import json_ready
from jsbsim_env.control.policy import PolicyFileError, PolicyRuntime
from training.evaluation.suite import evaluate


def why_null(path: str) -> str:
    """Why a metric of the suite has no value."""
    if "settling" in path:
        return "never settled: the error was still outside 10 % of the step when the next step came"
    if "steady_state" in path:
        return "no samples: the episode ended before this step's last 2 s"
    return "not a finite number"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--controller", choices=("policy", "pid"), default="policy",
                        help="the trained policy, or the gain-scheduled PID baseline")
    parser.add_argument("--policy", type=Path, help="policy file (.pt); the shipped controller when omitted")
    parser.add_argument("--episodes", type=int, default=50, help="seeded training-style episodes (at least 1)")
    parser.add_argument("--plots", type=Path, help="folder for the doublet plots (none when omitted)")
    parser.add_argument("--backend", choices=("onnx", "torch"), default="onnx",
                        help="runtime of the policy: onnxruntime or PyTorch")
    parser.add_argument("--json", action="store_true", help="print the metrics as JSON (no progress bar)")
    args = parser.parse_args(argv)
    if args.controller == "pid" and (args.policy or args.backend != "onnx"):
        parser.error("--policy and --backend are for --controller policy")
    if args.episodes < 1:
        parser.error(f"--episodes must be at least 1, got {args.episodes}")
    torch.set_num_threads(1)
    if args.controller == "pid":
        controller, about = PIDAttitudeController(), {"name": "gain-scheduled PID"}
    else:
        try:
            controller = PolicyRuntime(args.policy, backend=args.backend)
        except PolicyFileError as err:
            print(f"evaluate: {err}", file=sys.stderr)
            return 2
        about = {"name": "policy", **{k: v for k, v in controller.meta.items() if k not in ("network", "stack")},
                 "stack": controller.meta["stack"].to_dict()}
    results = evaluate(controller, episodes=args.episodes, plot_dir=args.plots, progress=not args.json)
    results["controller"] = about
    nulls: dict[str, str] = {}
    results = json_ready(results, why_null, nulls)
    results["null_values"] = nulls  # each metric printed as null, and why
    print(json.dumps(results, indent=2, allow_nan=False, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
