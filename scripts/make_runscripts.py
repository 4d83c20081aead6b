"""Rewrite the trimmed initial conditions and the doublet runscripts (see jsbsim_env.analysis.runscripts).

    python scripts/make_runscripts.py                    # the paper's aircraft, in the repository
    python scripts/make_runscripts.py --aircraft DIR     # an aircraft built into DIR, there

Rewriting them is the command's purpose: the files are generated from the model and kept in git,
so a run again regenerates them (the same files for the same model).
"""

from pathlib import Path

from training.runtime import ScriptParser, run_command

REPO_ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--aircraft", default=None,
                        help="a folder built by scripts/build_aircraft.py --out: its files are written under its JSBSim "
                             "root (default: the paper's aircraft, in the repository)")
    args = parser.parse_args(argv)
    from aircraft import AircraftError, load_aircraft
    from aircraft.design.xml_writer import write
    from jsbsim_env.analysis.runscripts import generated_files

    try:
        flown = load_aircraft(args.aircraft)
    except AircraftError as err:
        parser.exit(2, f"make_runscripts: --aircraft: {err}\n")
    root = REPO_ROOT if args.aircraft is None else flown.root
    files = generated_files(flown=flown)
    write(files, root)
    for rel in files:
        print(f"wrote {root / rel}")
    return 0


if __name__ == "__main__":
    run_command(main, __file__)
