"""Rewrite the trimmed initial conditions and the doublet runscripts (see jsbsim_env.analysis.runscripts)."""

from pathlib import Path

from jsbsim_env.analysis.runscripts import generated_files

REPO_ROOT = Path(__file__).resolve().parents[1]

if __name__ == "__main__":
    for rel, text in generated_files().items():
        path = REPO_ROOT / rel
        path.write_text(text)
        print(f"wrote {rel}")
