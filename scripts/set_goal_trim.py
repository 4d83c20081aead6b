"""Set the goal trim a policy file flies with (``jsbsim_env.controllers.goal_trim``), in place.

    python scripts/set_goal_trim.py runs/<name>/best_policy.pt --time-constant 20

The goal trim is a flight-time setting, recorded in the policy file and applied by
``PolicyRuntime``; training episodes go without it. New runs record ``--env.goal_trim_s`` (20 s by
default); this gives a policy trained before that setting existed (or any other) the same.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from training.policy import load_policy, set_goal_trim


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("policies", type=Path, nargs="+", help="policy files (.pt)")
    parser.add_argument("--time-constant", type=float, default=20.0, help="seconds; 0 turns the goal trim off")
    args = parser.parse_args()
    for path in args.policies:
        set_goal_trim(path, args.time_constant)
        print(f"{path}: goal trim {load_policy(path)[1]['goal_trim_s']:g} s")


if __name__ == "__main__":
    main()
