"""Fly the shipped controller (or ``--policy PATH``, or the PID baseline) on the fixed evaluation
suite and print the metrics.

    python scripts/evaluate.py --json                   # metrics as JSON
    python scripts/evaluate.py --plots results/eval     # and the Fig. 9 time histories
    python scripts/evaluate.py --controller pid --json  # the gain-scheduled PID on the same suite
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from jsbsim_env.controllers.pid import PIDAttitudeController
from training.evaluate import evaluate
from training.policy import PolicyRuntime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--controller", choices=("policy", "pid"), default="policy",
                        help="the trained policy, or the gain-scheduled PID baseline")
    parser.add_argument("--policy", type=Path, help="policy file (default: the shipped controller)")
    parser.add_argument("--episodes", type=int, default=50, help="seeded training-style episodes")
    parser.add_argument("--plots", type=Path, help="folder for the doublet plots")
    parser.add_argument("--backend", choices=("onnx", "torch"), default="onnx")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.controller == "pid" and (args.policy or args.backend != "onnx"):
        parser.error("--policy and --backend are for --controller policy")
    torch.set_num_threads(1)
    if args.controller == "pid":
        controller, about = PIDAttitudeController(), {"name": "gain-scheduled PID"}
    else:
        controller = PolicyRuntime(args.policy, backend=args.backend)
        about = {"name": "policy", **{k: v for k, v in controller.meta.items() if k != "network"}}
    results = evaluate(controller, episodes=args.episodes, plot_dir=args.plots, progress=not args.json)
    results["controller"] = about
    print(json.dumps(results, indent=2, default=float))


if __name__ == "__main__":
    main()
