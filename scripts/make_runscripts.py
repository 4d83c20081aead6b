"""Rewrite the trimmed initial conditions and the doublet runscripts (see jsbsim_env.analysis.runscripts).

    python scripts/make_runscripts.py
"""

import argparse
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    parser.parse_args(argv)  # no options: --help describes the command instead of running it
    from jsbsim_env.analysis.runscripts import generated_files

    for rel, text in generated_files().items():
        path = REPO_ROOT / rel
        path.write_text(text)
        print(f"wrote {rel}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
