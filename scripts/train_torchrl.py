"""Train the recurrent SAC attitude controller (defaults: SPEC section 3, with the changes the README gives).

    python scripts/train_torchrl.py                         # default run, folder runs/<name>
    python scripts/train_torchrl.py --seed 1 --collector.total_frames 50000
    python scripts/train_torchrl.py --resume runs/<name>    # continue a stopped run
    python scripts/train_torchrl.py --help                  # every setting
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from training.config import PRESETS, TrainConfig
from training.provenance import append_session
from training.runtime import tune_allocator
from training.trainer import Trainer


def main(argv: list[str] | None = None) -> int:
    # Each setting's help already names its default (the parser's own defaults are None, so that
    # a resume can tell which settings were given).
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--resume", type=Path, metavar="RUN_DIR", help="continue the run in this folder")
    parser.add_argument("--run-name", help="folder name under --log.run_root (default: seed and time)")
    parser.add_argument("--preset", choices=PRESETS, default="default",
                        help="starting configuration the other options change: this package's, or the paper's "
                             "(SPEC section 3; default: default)")
    TrainConfig.add_arguments(parser)
    args = parser.parse_args(argv)
    tune_allocator()
    if args.resume and args.preset != "default":
        parser.error("--preset starts a new run; a resumed run keeps the settings it was started with")
    if args.resume:
        saved = TrainConfig.from_dict(json.loads((args.resume / "config.json").read_text()))
        config = TrainConfig.from_namespace(args, base=saved)
        run_dir = args.resume
    else:
        config = TrainConfig.from_namespace(args, base=TrainConfig.preset(args.preset))
        name = args.run_name or f"sac_seed{config.seed}_{time.strftime('%Y%m%d-%H%M%S')}"
        run_dir = Path(config.log.run_root) / name
    trainer = Trainer(config, run_dir, resume=args.resume is not None)
    append_session(run_dir, ["python", "scripts/train_torchrl.py", *(sys.argv[1:] if argv is None else argv)],
                   trainer.counters.frames)
    print(f"run folder: {run_dir}", file=sys.stderr)
    last = trainer.train()
    print(json.dumps({"run_dir": str(run_dir), **last}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
