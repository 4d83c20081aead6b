"""Set the flight-time trim settings of policy files, in place.

    python scripts/set_trims.py runs/<name>/best_policy.pt --goal-trim-s 20
    python scripts/set_trims.py runs/<name>/best_policy.pt --integral-trim 1.0

The goal trim (``jsbsim_env.control.goal_trim``) is a flight-time setting: recorded in the
policy file and applied by ``PolicyRuntime``; training episodes go without it. New runs record
``--env.goal_trim_s`` (20 s by default); this gives any other policy the same. The integral trim's
gains (a fraction of the PID's integral gains, ``--env.integral_trim`` in training) may be changed
for a policy trained with hidden integral trims: its observation does not depend on them.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from jsbsim_env.control.policy import load_policy, set_goal_trim, set_integral_trim


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("policies", type=Path, nargs="+", help="policy files (.pt)")
    parser.add_argument("--goal-trim-s", type=float, default=None,
                        help="goal trim time constant in seconds; 0 turns the goal trim off (unset: unchanged)")
    parser.add_argument("--integral-trim", type=float, default=None,
                        help="integral trim gains as a fraction of the PID's integral gains, in (0, 2] "
                             "(unset: unchanged)")
    args = parser.parse_args()
    if args.goal_trim_s is None and args.integral_trim is None:
        parser.error("nothing to set: give --goal-trim-s and/or --integral-trim")
    for path in args.policies:
        if args.goal_trim_s is not None:
            set_goal_trim(path, args.goal_trim_s)
        if args.integral_trim is not None:
            set_integral_trim(path, args.integral_trim)
        meta = load_policy(path)[1]
        print(f"{path}: goal trim {meta['goal_trim_s']:g} s, integral trim {meta['integral_trim']:g}")


if __name__ == "__main__":
    main()
