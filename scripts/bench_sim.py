"""Raw JSBSim speed: ``fdm.run()`` steps per second of the solar UAV and of JSBSim's own c172x.

Both run in this process, interleaved in rounds so that the machine's load affects them alike;
the figures are medians over the rounds.

    python scripts/bench_sim.py --json
"""

from __future__ import annotations

import json
import os
import statistics
import time

import jsbsim

import aircraft
from training.runtime import ScriptParser, number_type, rounds_int, run_command

SIM_RATE_HZ = 120.0


def _solar_uav():
    fdm = jsbsim.FGFDMExec(str(aircraft.jsbsim_root()), None)
    fdm.set_debug_level(0)
    fdm.load_model(aircraft.AIRCRAFT_NAME)
    fdm.load_ic("cruise_10km", True)
    fdm.set_dt(1.0 / SIM_RATE_HZ)
    fdm.run_ic()
    fdm["fcs/throttle-cmd-norm[0]"] = 0.24
    return fdm


def _c172x():
    fdm = jsbsim.FGFDMExec(jsbsim.get_default_root_dir(), None)
    fdm.set_debug_level(0)
    fdm.load_model("c172x")
    fdm.load_ic("reset01", True)
    fdm.set_dt(1.0 / SIM_RATE_HZ)
    fdm.run_ic()
    fdm["propulsion/set-running"] = -1
    fdm["fcs/throttle-cmd-norm"] = 0.7
    return fdm


def steps_per_second(fdm, steps: int) -> float:
    run = fdm.run
    t0 = time.perf_counter()
    for _ in range(steps):
        run()
    return steps / (time.perf_counter() - t0)


def main(argv: list[str] | None = None) -> None:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=number_type(int, 1, 10_000_000), default=3000, help="fdm.run() calls per round and aircraft")
    parser.add_argument("--rounds", type=rounds_int, default=7, help="repeats of each measurement; the median is reported")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args(argv)
    os.environ.setdefault("JSBSIM_DEBUG", "0")
    rates = {"solar_uav": [], "c172x": []}
    for _ in range(args.rounds):
        # A fresh instance each round keeps both aircraft in comparable flight states.
        for name, make in (("solar_uav", _solar_uav), ("c172x", _c172x)):
            rates[name].append(steps_per_second(make(), args.steps))
    result = {
        "sim_rate_hz": SIM_RATE_HZ, "steps_per_round": args.steps, "rounds": args.rounds,
        "solar_uav_steps_per_s": statistics.median(rates["solar_uav"]),
        "c172x_steps_per_s": statistics.median(rates["c172x"]),
        "ratio_solar_uav_to_c172x": statistics.median(a / b for a, b in zip(rates["solar_uav"], rates["c172x"])),
        "jsbsim_version": jsbsim.__version__,
    }
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        for k, v in result.items():
            print(f"{k:28s} {v}")


if __name__ == "__main__":
    run_command(main, __file__)
