"""Copy a run's best deterministic policy into the package, with its ONNX export and a record of
where it came from (run command, seed, commit, configuration, evaluation figures).

    python scripts/ship_policy.py runs/<name> --episodes 50

The commands and commits come from the run's ``sessions.jsonl`` (written by every training
session); ``--command`` and ``--commit`` stand in for a run that has none.
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

import torch

from training.evaluate import evaluate
from training.policy import SHIPPED_POLICY, PolicyRuntime, export_onnx, load_policy
from training.provenance import read_sessions

SHIPPED_DIR = Path(__file__).resolve().parents[1] / "training" / "shipped"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--command", help="the training command, for a run without sessions.jsonl")
    parser.add_argument("--commit", help="the commit it was trained at, for a run without sessions.jsonl")
    parser.add_argument("--episodes", type=int, default=50)
    args = parser.parse_args()
    sessions = read_sessions(args.run_dir)
    if not sessions:
        if not (args.command and args.commit):
            parser.error(f"{args.run_dir} has no sessions.jsonl: give --command and --commit")
        sessions = [{"command": args.command, "commit": args.commit, "frames_at_start": 0}]
    torch.set_num_threads(1)
    SHIPPED_DIR.mkdir(parents=True, exist_ok=True)
    target = SHIPPED_DIR / SHIPPED_POLICY
    shutil.copyfile(args.run_dir / "best_policy.pt", target)
    actor, meta = load_policy(target)
    export_onnx(actor, target.with_suffix(".onnx"), int(meta["window"]))
    sessions = [s for s in sessions if s["frames_at_start"] < meta["frames"]]  # those that trained this policy
    results = evaluate(PolicyRuntime(target), episodes=args.episodes, plot_dir=None)
    record = {
        "command": sessions[0]["command"], "commit": sessions[0]["commit"], "sessions": sessions,
        "seed": meta["seed"], "frames": meta["frames"],
        "training_evaluation": meta["evaluation"],
        "config": json.loads((args.run_dir / "config.json").read_text()),
        "evaluation": results,
    }
    target.with_suffix(".json").write_text(json.dumps(record, indent=2, default=float))
    print(json.dumps({k: v for k, v in record.items() if k != "config"}, indent=2, default=float))


if __name__ == "__main__":
    main()
