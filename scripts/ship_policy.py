"""Copy a run's best deterministic policy into the package, with its ONNX export and a record of
where it came from (run command, seed, commit, configuration, evaluation figures).

    python scripts/ship_policy.py runs/<name> --command "python scripts/train_torchrl.py --seed 0" --episodes 50
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
from pathlib import Path

import torch

from training.evaluate import evaluate
from training.policy import SHIPPED_POLICY, PolicyRuntime, export_onnx, load_policy

SHIPPED_DIR = Path(__file__).resolve().parents[1] / "training" / "shipped"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--command", required=True, help="the exact training command of the run")
    parser.add_argument("--commit", help="commit the run was trained at (default: the run's record, else HEAD)")
    parser.add_argument("--episodes", type=int, default=50)
    args = parser.parse_args()
    torch.set_num_threads(1)
    SHIPPED_DIR.mkdir(parents=True, exist_ok=True)
    target = SHIPPED_DIR / SHIPPED_POLICY
    shutil.copyfile(args.run_dir / "best_policy.pt", target)
    actor, meta = load_policy(target)
    export_onnx(actor, target.with_suffix(".onnx"), int(meta["window"]))
    commit = args.commit or subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                                           check=False, cwd=SHIPPED_DIR).stdout.strip()
    results = evaluate(PolicyRuntime(target), episodes=args.episodes, plot_dir=None)
    record = {
        "command": args.command, "seed": meta["seed"], "commit": commit, "frames": meta["frames"],
        "training_evaluation": meta["evaluation"],
        "config": json.loads((args.run_dir / "config.json").read_text()),
        "evaluation": results,
    }
    target.with_suffix(".json").write_text(json.dumps(record, indent=2, default=float))
    print(json.dumps({k: v for k, v in record.items() if k != "config"}, indent=2, default=float))


if __name__ == "__main__":
    main()
