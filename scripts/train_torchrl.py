"""Train the recurrent SAC attitude controller (the task version SolarUAVAttitude-v1 by default).

    python scripts/train_torchrl.py                         # default run, folder runs/<name>
    python scripts/train_torchrl.py --seed 1 --collector.total_frames 50000
    python scripts/train_torchrl.py --env.task SolarUAVAttitude-v0   # the paper's task (its Section 3.4)
    python scripts/train_torchrl.py --resume runs/<name>    # continue a stopped run
    python scripts/train_torchrl.py --help                  # every setting

A run is never started over another: a folder that holds a checkpoint or a best policy is refused
(resume it, or give another --run-name). A folder whose run stopped before its first checkpoint
holds nothing to resume, and the command that started it starts it afresh, replacing its logs.
Refusals are one line on stderr with exit code 2; a run folder that cannot be written during
training, or training that diverges (a loss or weight NaN or infinite), ends with one line naming
its last checkpoint, which is kept, and how to go on, exit code 1. A resumed run may change its
length (--collector.total_frames) and learning rate (--optim.lr); another changed setting is
refused, naming it.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

# Only what the parser needs is imported here: torch and TorchRL load after the arguments are
# parsed, so that a mistyped option is refused at once.
from training.config import TrainConfig, check_run_name
from training.runtime import ScriptParser, run_command, torchrl_logs_to_stderr, tune_allocator, workers_int

# Exit codes of a run stopped by a signal, as a shell reports them (128 + signal number).
_SIGNAL_EXIT = {"SIGINT": 130, "SIGTERM": 143}


def main(argv: list[str] | None = None) -> int:
    # Each setting's help already names its default (the parser's own defaults are None, so that
    # a resume can tell which settings were given).
    # allow_abbrev=False: an option is matched whole, never by prefix (``--env.num_env`` is an error,
    # not ``--env.num_envs``).
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0], formatter_class=argparse.HelpFormatter)
    parser.add_argument("--resume", type=Path, metavar="RUN_DIR",
                        help="continue the run in this folder from its last checkpoint")
    parser.add_argument("--run-name", help="the run's folder under --log.run_root: one plain name; a folder that "
                                           "holds a run is refused (default: seed and time)")
    parser.add_argument("--json", action="store_true",
                        help="print the last log row as JSON on stdout (everything else goes to stderr)")
    parser.add_argument("--seeds", help="train these seeds (comma-separated), each its own run "
                                        "<run-name>_seed<N>; the same command again resumes them (default: one run)")
    parser.add_argument("--backend", choices=("local", "ray"), default="local",
                        help="with --seeds: local processes, or Ray tasks (pip install '.[ray]') (default: local)")
    parser.add_argument("--workers", type=workers_int, default=1, help="with --seeds --backend local: processes (default: 1)")
    parser.add_argument("--address", help="with --backend ray: a Ray cluster's address ('auto': this machine's; "
                                          "default: a local Ray instance)")
    TrainConfig.add_arguments(parser)
    args = parser.parse_args(argv)
    if args.seeds is not None and args.resume:
        parser.error("--seeds resumes its runs itself: give the same command again instead of --resume")
    # Refusals before any work: one line each, exit code 2.
    try:
        if args.resume and args.run_name is not None:
            raise ValueError("--run-name is not used with --resume: the run goes on in its own folder")
        if args.run_name is not None:
            check_run_name(args.run_name)
    except ValueError as err:
        print(f"train_torchrl: {err}", file=sys.stderr)
        return 2
    # The command as the run's sessions record it.
    command = ["python", "scripts/train_torchrl.py", *(sys.argv[1:] if argv is None else argv)]
    if args.seeds is not None:
        return _train_seeds(args, command)
    torchrl_logs_to_stderr()
    tune_allocator()
    from jsbsim_env.control.gain_files import GainsMissing
    from training.checkpoint import CheckpointError
    from training.provenance import append_session
    from training.trainer import (
        RunExistsError,
        RunFolderError,
        RunLockedError,
        Trainer,
        TrainingDiverged,
        TrainingInterrupted,
    )

    try:
        if args.resume:
            config_path = args.resume / "config.json"
            if not config_path.is_file():
                raise CheckpointError(f"no run to resume at {args.resume} (it has no config.json)")
            saved = _read_config(config_path)
            config = TrainConfig.from_namespace(args, base=saved)
            run_dir = args.resume
        else:
            config = TrainConfig.from_namespace(args)
            name = args.run_name or f"sac_seed{config.seed}_{time.strftime('%Y%m%d-%H%M%S')}"
            run_dir = Path(config.log.run_root) / name
        trainer = Trainer(config, run_dir, resume=args.resume is not None)
    except (CheckpointError, GainsMissing, RunLockedError, RunExistsError, RunFolderError, ValueError) as err:
        print(f"train_torchrl: {err}", file=sys.stderr)  # refused before any training: exit 2
        return 2
    for note in trainer.notes:
        print(f"train_torchrl: {note}", file=sys.stderr)
    try:
        append_session(run_dir, command, trainer.counters.frames, trainer.aircraft.fingerprint)
    except OSError as err:
        print(f"train_torchrl: cannot write to the run folder {run_dir} ({err.strerror or err})", file=sys.stderr)
        return 1
    print(f"run folder: {run_dir}", file=sys.stderr)
    if args.resume:
        c = trainer.counters
        best = f"; best evaluation so far {c.best_eval:.3f}" if math.isfinite(c.best_eval) else ""
        print(f"train_torchrl: resuming from its checkpoint at {c.frames:,} of {config.collector.total_frames:,} "
              f"environment steps ({c.updates:,} updates{best})", file=sys.stderr)
    try:
        last = trainer.train()
    except TrainingInterrupted as stop:
        print(f"train_torchrl: stopped by {stop}; go on with: python scripts/train_torchrl.py --resume {run_dir}",
              file=sys.stderr)
        return _SIGNAL_EXIT.get(stop.signal_name, 1)
    except (RunFolderError, TrainingDiverged) as err:
        print(f"train_torchrl: {err}", file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps({"run_dir": str(run_dir), **last}, indent=2))
    else:
        best = run_dir / "best_policy.pt"
        kept = f"best policy: {best}" if best.is_file() else "no best policy (no evaluation has run)"
        print(f"trained to {trainer.counters.frames:,} env steps in {trainer.counters.wall_s:.0f} s; {kept}")
    return 0


def _read_config(path: Path) -> TrainConfig:
    """A run's ``config.json``; ``ValueError`` naming the file when it is not JSON or not a valid
    configuration."""
    try:
        data = json.loads(path.read_bytes().decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ValueError(f"{path} is not valid JSON ({err}): the run's configuration is damaged") from None
    except OSError as err:
        raise ValueError(f"cannot read {path} ({err.strerror or err})") from None
    try:
        return TrainConfig.from_dict(data)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{path}: {err}") from None


def _train_seeds(args, command: list[str]) -> int:
    """Several seeds of one configuration (``training.multiseed``), then their summary."""
    torchrl_logs_to_stderr()
    tune_allocator()
    from training.checkpoint import CheckpointError
    from training.multiseed import seeds_summary, train_seeds
    from training.trainer import RunFolderError

    try:
        try:
            seeds = [int(x) for x in args.seeds.split(",") if x.strip()]
        except ValueError:
            raise ValueError(f"--seeds must be comma-separated integers, got {args.seeds!r}") from None
        config = TrainConfig.from_namespace(args)
        name = args.run_name or f"sac_{time.strftime('%Y%m%d-%H%M%S')}"
        rows = train_seeds(config, seeds, name, command, args.backend, args.workers, args.address)
    except RunFolderError as err:
        print(f"train_torchrl: {err}", file=sys.stderr)
        return 1
    except (CheckpointError, ValueError, RuntimeError) as err:  # RunLockedError, RunExistsError: RuntimeError
        print(f"train_torchrl: {err}", file=sys.stderr)
        return 2
    root = Path(config.log.run_root)
    summary = seeds_summary([Path(r["run_dir"]) for r in rows], root / f"{name}_fig8.png")
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        for run in summary["runs"]:
            print(f"{run['run']}: {run['frames']:,} env steps, final evaluation return "
                  f"{run.get('final_eval_return', float('nan')):.3f}")
        if "final_eval_return" in summary:
            f = summary["final_eval_return"]
            print(f"over {f['seeds']} seeds: {f['mean']:.3f} ({f['min']:.3f}-{f['max']:.3f}); curves in {summary['figure']}")
    return 0


if __name__ == "__main__":
    run_command(main, __file__)
