"""Copy a run's best deterministic policy into the package, with its ONNX export and a record of
where it came from (run command, seed, commit, configuration, evaluation figures).

    python scripts/ship_policy.py runs/<name> --episodes 50

The commands and commits come from the run's ``sessions.jsonl`` (written by every training
session); ``--command`` and ``--commit`` give the first session of a run that started before
sessions were recorded.

Replacing the shipped policy is the command's purpose: the files it writes are the package's (kept
in git, so the policy shipped before stays in the history), and a run again with the same run
folder writes the same files. Everything is checked first (a policy trained on an aircraft other
than the package's is refused in one line, before anything is written); the policy, its export and
its record are then written and evaluated in a temporary folder beside the shipped one, and moved
into place together only when all succeeded: an error or a Ctrl-C leaves the shipped set as it was.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import sys
import tempfile
from pathlib import Path

# torch and the simulation load in main(), after the arguments are parsed.
from training.runtime import (
    OutputFolderError,
    ScriptParser,
    check_output_folder,
    episodes_int,
    run_command,
    workers_int,
)

SHIPPED_DIR = Path(__file__).resolve().parents[1] / "jsbsim_env" / "control" / "shipped"
STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM}


def swap_into(staging: Path, destination: Path, names: list[str]) -> None:
    """Move ``names`` from ``staging`` into ``destination`` (the same file system: each a rename),
    with Ctrl-C and SIGTERM held until all are in place, so that a stop never leaves a mixed set;
    a signal that came meanwhile is delivered afterwards."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        for name in names:
            os.replace(staging / name, destination / name)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--command", help="the training command, for a run without sessions.jsonl")
    parser.add_argument("--commit", help="the commit it was trained at, for a run without sessions.jsonl")
    parser.add_argument("--episodes", type=episodes_int, default=50, help="evaluation-suite episodes for the record")
    parser.add_argument("--cores", type=workers_int, help="CPU cores the run trained on, for a run whose sessions do not say")
    args = parser.parse_args(argv)
    import torch

    from aircraft import load_aircraft
    from jsbsim_env.control.policy import (
        SHIPPED_POLICY,
        PolicyFileError,
        PolicyRuntime,
        export_onnx,
        load_policy,
        policy_digest,
        trained_aircraft,
    )
    from training.config import TrainConfig
    from training.evaluation.suite import evaluate
    from training.provenance import read_sessions, training_wall_clock

    torch.set_num_threads(1)
    source = args.run_dir / "best_policy.pt"
    try:  # a clear error for a missing or broken file, before anything is copied
        actor, meta = load_policy(source)
    except PolicyFileError as err:
        print(f"ship_policy: {err}", file=sys.stderr)
        return 2
    package = load_aircraft(None)  # the aircraft the shipped policy flies
    name, model = trained_aircraft(meta, source)
    if model is not None and not package.matches_model(model):
        print(f"ship_policy: {source} was trained on {name} (model {model[:12]}); the package ships a policy of "
              f"its own aircraft, {package.name} (model {package.fingerprint[:12]}): ship a run trained on it",
              file=sys.stderr)
        return 2
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
    try:
        wall = training_wall_clock(args.run_dir, int(meta["frames"]))
    except ValueError as err:
        parser.error(str(err))
    # Each session's model the package's (a record made before the envelope joined the fingerprint
    # matches by the XML files: Aircraft.matches_model).
    other = sorted({m for s in sessions if (m := s.get("aircraft_model")) and not package.matches_model(m)})
    if other:
        parser.error(f"{args.run_dir}/sessions.jsonl records training on model {other[0][:12]}, not the "
                     f"package's {package.name} (model {package.fingerprint[:12]})")
    config_path = args.run_dir / "config.json"
    try:
        config = json.loads(config_path.read_text())
        TrainConfig.from_dict(config)  # a run of this version of the package, with a task version it has
    except (OSError, ValueError) as err:
        parser.error(f"{config_path}: {err}")
    try:
        check_output_folder(SHIPPED_DIR)
    except OutputFolderError as err:
        print(f"ship_policy: {err}", file=sys.stderr)
        return 2
    SHIPPED_DIR.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(dir=SHIPPED_DIR.parent, prefix=f".staging_{SHIPPED_DIR.name}_"))
    try:
        target = staging / SHIPPED_POLICY
        shutil.copyfile(source, target)
        stack = meta["stack"]  # the control stack the policy was trained with and flies with
        export_onnx(actor, target.with_suffix(".onnx"), stack.window_steps, policy_digest(target))
        results = evaluate(PolicyRuntime(target), episodes=args.episodes, plot_dir=None)
        record = {
            "command": sessions[0]["command"], "commit": sessions[0]["commit"], "sessions": sessions,
            "aircraft_model": sessions[-1].get("aircraft_model"),  # the model of its last session
            "seed": meta["seed"], "frames": meta["frames"],
            # training time to this policy (all sessions), on this many cores; the run went on to its last row
            "wall_clock_s": wall["to_policy_s"], "cpu_cores": cores.pop(),
            "run_wall_clock_s": wall["whole_run_s"], "run_frames": wall["frames"],
            "training_evaluation": meta["evaluation"],
            "config": config,
            # what the policy was trained on and flies with: the task version and the control stack's settings
            "task": meta.get("task"),
            "stack": stack.to_dict(),
            "evaluation": results,
        }
        target.with_suffix(".json").write_text(json.dumps(record, indent=2, default=float))
        # The export and the record first, the policy file last: the runtime refuses no intermediate set
        # (an export of another file is made again), and the signals are held while they move.
        swap_into(staging, SHIPPED_DIR, [target.with_suffix(".onnx").name, target.with_suffix(".json").name,
                                         target.name])
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    print(json.dumps({k: v for k, v in record.items() if k != "config"}, indent=2, default=float))
    return 0


if __name__ == "__main__":
    run_command(main, __file__)
