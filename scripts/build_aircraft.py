"""Build an aircraft's aerodynamic tables and JSBSim files from its description file (the paper's aircraft by default).

With ``--out DIR`` it then designs the aircraft's classical controllers, the PID and the LQI, by
the procedures that designed the paper's aircraft's (``jsbsim_env.control.classical_design``), into
its folder, and writes the standalone JSBSim runs (``jsbsim_env.analysis.runscripts``: trimmed
initial conditions and doublet runscripts, ``DIR/scripts/*.xml``). Then the build report: the
stability figures and the analysis's checks, and the built model's survey (trims across its envelope, linear modes at cruise; ``jsbsim_env.analysis.survey``),
printed and, with ``--out DIR``, written to ``DIR/build_report.md``.

Every check comes before any work: the description's (its plausibility included), and the
destination's: ``--out`` must be a new or empty folder (``--from-data`` rewrites an earlier build of
the same description), and only the package's own description builds into the package. The build
is written into a temporary folder beside its destination and moved into place only when all of it
succeeded: an error or Ctrl-C leaves nothing half-built.
"""

import sys

from aircraft.design.build import BuildError, build_into, build_parser, prepare, staging, summary
from training.runtime import run_command


def main(argv: list[str] | None = None) -> int:
    parser = build_parser(__doc__)
    parser.add_argument("--no-survey", action="store_true", help="skip the trims and modes of the built model")
    parser.add_argument("--no-controllers", action="store_true",
                        help="skip the design of the PID and the LQI (with --out; the paper's aircraft's ship with the "
                             "package)")
    args = parser.parse_args(argv)
    try:
        # Every check before any work; everything is then written into a temporary folder, moved
        # into place only when all of it succeeded.
        target = prepare(args.description, args.out, args.from_data)
        with staging(target) as root:
            text = _build(target, root, args)
    except BuildError as err:
        print(f"build_aircraft: {err}", file=sys.stderr)
        return 2
    print(text)
    return 0


def _build(target, root, args) -> str:
    """Build ``target`` into the temporary JSBSim root ``root``; the build report's text (written
    into ``root`` with ``--out``). Paths in what it prints and reports are the final ones."""

    def final(line: str) -> str:
        return line.replace(str(root), str(target.root))

    def log(line: str) -> None:
        print(final(line), flush=True)

    built = build_into(target, root, log)
    g = built.geometry
    lines = [f"# {g.name}: build report", "", g.description, "", "```", summary(built.data), "```"]
    if args.out is not None and not args.no_controllers:
        from jsbsim_env.control.classical_design import design_classical

        designed = []
        design_classical(built.folder, log=lambda line: (log(line), designed.append(final(line))))
        lines += ["", "## Classical controllers", "", *(f"- {line}" for line in designed)]
    if args.out is not None:
        from aircraft.design.xml_writer import write
        from jsbsim_env.analysis.runscripts import generated_files

        runs = generated_files(flown=built.folder)
        write(runs, root)
        lines += ["", "## Standalone JSBSim runs", "", *(f"- `{rel}`" for rel in runs if rel.startswith("scripts/")),
                  "", f"Run one from `{args.out}`: `jsbsim --root . scripts/NAME.xml`."]
    if not args.no_survey:
        from jsbsim_env.analysis.survey import envelope_survey, render_survey, render_trim_grid, trim_grid

        rows = envelope_survey(built.folder)
        lines += ["", "## Trims, static margin and modes across the envelope", "",
                  *render_survey(rows, built.geometry.motor_efficiency)]
        lines += ["", "## The trim table", "", ("Every point of the grid the episodes start from "
                  "(jsbsim_env.sim.trim_table): angle of attack / elevator (deg) / throttle."), "",
                  *render_trim_grid(*trim_grid(built.folder))]
    text = final("\n".join(lines) + "\n")
    if args.out is not None:
        (root / "build_report.md").write_text(text)
    return text


if __name__ == "__main__":
    run_command(main, __file__)
