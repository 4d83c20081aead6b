"""Rewrite the trimmed initial conditions and the doublet runscripts (see jsbsim_env.analysis.runscripts).

    python scripts/make_runscripts.py

Rewriting them is the command's purpose: the files are generated from the model and kept in git,
so a run again regenerates them (the same files for the same model).
"""

from pathlib import Path

from training.runtime import ScriptParser

REPO_ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.parse_args(argv)  # no options: --help describes the command instead of running it
    from jsbsim_env.analysis.runscripts import generated_files

    for rel, text in generated_files().items():
        path = REPO_ROOT / rel
        path.write_text(text)
        print(f"wrote {rel}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
