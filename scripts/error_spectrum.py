"""Where in frequency a controller leaves its attitude errors in the benchmark's turbulence.

    python scripts/error_spectrum.py --controllers policy,lqi_tuned --altitude-m 10000
    python scripts/error_spectrum.py --controllers policy --policy runs/a/best_policy.pt --episodes 4

Flies the benchmark's turbulence flight (``training.evaluation.benchmark``, the straight leg and its
window) on the validation seeds and prints, per controller, the share of the roll, pitch and
sideslip errors' fluctuation power in frequency bands, and the mean change of the aileron and
elevator commands per control step, each the mean over the realisations
(``training.evaluation.spectrum``).
"""

from __future__ import annotations

import sys

from jsbsim_env.control.factory import CONTROLLER_NAMES
from training.runtime import ScriptParser, episodes_int, name_list, number_type, run_command


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--controllers", default="policy,lqi_tuned", help=f"comma-separated: {', '.join(CONTROLLER_NAMES)}")
    parser.add_argument("--policy", default=None, help="policy file of the policy controller (the shipped one when omitted)")
    parser.add_argument("--altitude-m", type=number_type(float, 0.0, 20000.0, unit="m"), default=10000.0,
                        help="the turbulence flight's altitude (the benchmark's: 1000, 10000, 20000)")
    parser.add_argument("--episodes", type=episodes_int, default=3, help="validation realisations, from the first")
    args = parser.parse_args(argv)
    try:
        names = name_list(args.controllers, CONTROLLER_NAMES, "--controllers")
    except ValueError as err:
        print(f"error_spectrum: {err}", file=sys.stderr)
        return 2

    import numpy as np

    from jsbsim_env.control.factory import check_flyable, make_controller
    from jsbsim_env.control.gain_files import GainsMissing, GainTableError
    from jsbsim_env.control.policy import PolicyFileError, shipped_policy_path

    try:  # every gain table and policy file read and checked once, before any flight
        check_flyable(names, policies={"policy": args.policy or shipped_policy_path()} if "policy" in names else None)
    except (PolicyFileError, GainsMissing, GainTableError) as err:
        print(f"error_spectrum: {err}", file=sys.stderr)
        return 2
    from jsbsim_env.missions import fly_route
    from jsbsim_env.sim.trim_table import TrimTable
    from training.evaluation.benchmark import BenchJob, BenchmarkPlan, route_config
    from training.evaluation.spectrum import BANDS_HZ, band_shares, mean_step_change

    plan = BenchmarkPlan()
    start_s, end_s = plan.leg_window_s
    bands = " ".join(f"{lo:g}-{hi:g}" for lo, hi in BANDS_HZ)
    print(f"share of error power per band (Hz: {bands}); mean command change per step (deg)")
    for name in names:
        shares, changes = [], []
        for k in range(args.episodes):
            TrimTable.forget_shared()
            job = BenchJob("turbulence", {"altitude_m": args.altitude_m}, name, k, split="validation")
            result = fly_route(make_controller(name, args.policy), route_config(job, plan))
            if result.ended_early:
                print(f"error_spectrum: {name} ended realisation {k} early: {result.ended_early}", file=sys.stderr)
                return 2
            a = result.arrays
            t = a["time_s"]
            window = (t >= start_s) & (t <= end_s)
            dt_s = float(np.median(np.diff(t[window])))
            errors = (a["roll_rad"] - a["roll_cmd_rad"], a["pitch_rad"] - a["pitch_cmd_rad"], a["beta_rad"])
            shares.append([band_shares(np.degrees(e[window]), dt_s) for e in errors])
            changes.append([mean_step_change(a["command"][window][:, j]) for j in (0, 1)])
        s, c = np.mean(shares, axis=0), np.mean(changes, axis=0)
        for axis, row in zip(("roll", "pitch", "sideslip"), s):
            print(f"{name:10s} {axis:8s} " + " ".join(f"{v:.2f}" for v in row))
        print(f"{name:10s} aileron {c[0]:.3f}, elevator {c[1]:.3f} deg per step")
    return 0


if __name__ == "__main__":
    run_command(main, __file__)
