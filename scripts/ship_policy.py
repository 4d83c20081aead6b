"""Copy a run's best deterministic policy into the package, with its ONNX export and a record of
where it came from (run command, seed, commit, configuration, evaluation figures).

    python scripts/ship_policy.py runs/<name> --episodes 50

The commands and commits come from the run's ``sessions.jsonl`` (written by every training
session); ``--command`` and ``--commit`` give the first session of a run that started before
sessions were recorded.
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

import torch

from training.config import TrainConfig
from jsbsim_env.control.policy import SHIPPED_POLICY, PolicyRuntime, export_onnx, load_policy, policy_digest
from training.provenance import read_sessions, training_wall_clock
from training.evaluation.suite import evaluate

SHIPPED_DIR = Path(__file__).resolve().parents[1] / "jsbsim_env" / "control" / "shipped"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--command", help="the training command, for a run without sessions.jsonl")
    parser.add_argument("--commit", help="the commit it was trained at, for a run without sessions.jsonl")
    parser.add_argument("--episodes", type=int, default=50, help="evaluation-suite episodes for the record")
    parser.add_argument("--cores", type=int, help="CPU cores the run trained on, for a run whose sessions do not say")
    args = parser.parse_args()
    torch.set_num_threads(1)
    source = args.run_dir / "best_policy.pt"
    actor, meta = load_policy(source)  # a clear error for a missing or broken file, before anything is copied
    sessions = read_sessions(args.run_dir)
    recorded_from_start = bool(sessions) and sessions[0]["frames_at_start"] == 0
    if recorded_from_start and (args.command or args.commit):
        parser.error(f"{args.run_dir}/sessions.jsonl records the whole run: --command and --commit are not needed")
    if not recorded_from_start:
        if not (args.command and args.commit):
            parser.error(f"{args.run_dir}/sessions.jsonl does not record the run's first session: "
                         "give its --command and --commit")
        sessions.insert(0, {"command": args.command, "commit": args.commit, "dirty": None, "frames_at_start": 0})
    sessions = [s for s in sessions if s["frames_at_start"] < meta["frames"]]  # those that trained this policy
    cores = {s["cpu_cores"] for s in sessions if "cpu_cores" in s} | ({args.cores} if args.cores else set())
    if len(cores) != 1:
        parser.error(f"the cores the run trained on are {'unknown: give --cores' if not cores else sorted(cores)}")
    wall = training_wall_clock(args.run_dir, int(meta["frames"]))
    models = {s.get("aircraft_model") for s in sessions}
    if len(models) > 1:
        parser.error(f"{args.run_dir} was trained on more than one aircraft model ({sorted(map(str, models))})")
    config = json.loads((args.run_dir / "config.json").read_text())
    trained = TrainConfig.from_dict(config).env  # settings the run predates take the values it trained with
    SHIPPED_DIR.mkdir(parents=True, exist_ok=True)
    target = SHIPPED_DIR / SHIPPED_POLICY
    shutil.copyfile(source, target)
    export_onnx(actor, target.with_suffix(".onnx"), int(meta["window"]), policy_digest(target))
    results = evaluate(PolicyRuntime(target), episodes=args.episodes, plot_dir=None)
    record = {
        "command": sessions[0]["command"], "commit": sessions[0]["commit"], "sessions": sessions,
        "aircraft_model": models.pop(),
        "seed": meta["seed"], "frames": meta["frames"],
        # training time to this policy (all sessions), on this many cores; the run went on to its last row
        "wall_clock_s": wall["to_policy_s"], "cpu_cores": cores.pop(),
        "run_wall_clock_s": wall["whole_run_s"], "run_frames": wall["frames"],
        "training_evaluation": meta["evaluation"],
        "config": config,
        # flight-time settings: scripts/set_trims.py may have set them after training
        "goal_trim_s": meta["goal_trim_s"],
        "goal_trim_set_after_training": trained.goal_trim_s != meta["goal_trim_s"],
        "integral_trim": meta["integral_trim"],
        "integral_trim_set_after_training": trained.flown_integral_trim != meta["integral_trim"],
        "evaluation": results,
    }
    target.with_suffix(".json").write_text(json.dumps(record, indent=2, default=float))
    print(json.dumps({k: v for k, v in record.items() if k != "config"}, indent=2, default=float))


if __name__ == "__main__":
    main()
